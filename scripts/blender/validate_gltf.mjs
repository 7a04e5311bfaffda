#!/usr/bin/env node
// SPDX-License-Identifier: MIT
// Validates glTF 2.0 files (.gltf with external .bin/.png, or .glb) with the Khronos glTF
// Validator (npm package gltf-validator, a JS library compiled from Dart), prints each
// report's error / warning / info / hint counts and its messages, and exits 1 when any file
// has an error (or cannot be read), 0 otherwise.
//
//   node scripts/blender/validate_gltf.mjs data/scenes/import/*.gltf
//
// The package is looked up next to this script, in the current directory, in $NODE_PATH and
// in the global npm root (`npm install -g gltf-validator`); GLTF_VALIDATOR names its folder
// explicitly. External resources (buffers, images) are read relative to each file.

import { execSync } from 'node:child_process';
import fs from 'node:fs';
import { createRequire } from 'node:module';
import path from 'node:path';
import { fileURLToPath } from 'node:url';

const here = path.dirname(fileURLToPath(import.meta.url));
const require = createRequire(import.meta.url);

function loadValidator() {
  if (process.env.GLTF_VALIDATOR) return require(path.resolve(process.env.GLTF_VALIDATOR));
  const paths = [here, process.cwd(), ...(process.env.NODE_PATH || '').split(path.delimiter)]
    .filter(Boolean);
  try {
    paths.push(execSync('npm root -g', { encoding: 'utf8', stdio: ['ignore', 'pipe', 'ignore'] })
      .trim());
  } catch {
    // no npm: only the paths above
  }
  for (const p of paths) {
    try {
      return require(require.resolve('gltf-validator', { paths: [p] }));
    } catch {
      // not there
    }
  }
  console.error('validate_gltf: npm package gltf-validator not found; install it with\n' +
                '  npm install -g gltf-validator');
  process.exit(2);
}

const SEVERITY = ['error', 'warning', 'info', 'hint'];

async function validate(validator, file) {
  const bytes = new Uint8Array(fs.readFileSync(file));
  const dir = path.dirname(path.resolve(file));
  return validator.validateBytes(bytes, {
    uri: path.basename(file),
    maxIssues: 0, // all of them
    writeTimestamp: false,
    externalResourceFunction: (uri) =>
      new Promise((resolve, reject) => {
        fs.readFile(path.resolve(dir, decodeURIComponent(uri)), (err, data) => {
          if (err) reject(err.toString());
          else resolve(new Uint8Array(data));
        });
      }),
  });
}

async function main() {
  const files = process.argv.slice(2);
  if (files.length === 0) {
    console.error('usage: node scripts/blender/validate_gltf.mjs FILE.gltf|FILE.glb ...');
    process.exit(2);
  }
  const validator = loadValidator();
  console.log(`glTF Validator ${validator.version()}`);
  let failed = false;
  for (const file of files) {
    let report;
    try {
      report = await validate(validator, file);
    } catch (e) {
      console.log(`${file}: cannot validate: ${e}`);
      failed = true;
      continue;
    }
    const is = report.issues;
    const info = report.info || {};
    const res = (info.resources || []).map((r) => `${r.uri || r.pointer} ${r.byteLength ?? '?'} B`);
    console.log(`${file}: ${is.numErrors} errors, ${is.numWarnings} warnings, ${is.numInfos} ` +
                `infos, ${is.numHints} hints (generator ${info.generator ?? '-'}; ` +
                `${info.drawCallCount ?? '-'} draw calls, ${info.totalTriangleCount ?? '-'} ` +
                `triangles, ${info.totalVertexCount ?? '-'} vertices; resources: ` +
                `${res.join(', ') || '-'})`);
    for (const m of is.messages) {
      console.log(`  ${SEVERITY[m.severity] || m.severity}: ${m.code}: ${m.message}` +
                  `${m.pointer ? ` (${m.pointer})` : ''}`);
    }
    if (is.numErrors > 0) failed = true;
  }
  process.exit(failed ? 1 : 0);
}

main();
