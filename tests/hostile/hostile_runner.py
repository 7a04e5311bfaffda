#!/usr/bin/env python3
# SPDX-License-Identifier: MIT
"""The hostile-input runner (issue 18; tests/hostile/README.md has the case format).

Runs every case of tests/hostile/cases/*.json (named reproductions and generated variants:
huge / tiny / NaN / Inf / negative values in every numeric field of a level JSON, a glTF
scene, the CLI flags, the C API arguments, poked-and-resealed binary files), each under a
timeout in its own temporary directory, and classifies each run:

  ok         exit 0 and every output checked: finite, non-negative, not all zero where
             light reaches the samples, under the case's bound
  clean      a clean error: exit status 1, 2 or CLI11's 100-125, no signal, stderr names the field
  crash      a signal, a sanitizer report, an uncaught exception, an unexpected exit status
  hang       the timeout expired
  wrong      silent wrong output: exit 0 with NaN / Inf / negative / all-zero / implausible
             output, a missing output, or exit 0 where a clean error was expected
  bad error  an error whose message does not name the field (or an error where the input
             is valid and must be accepted)
  skipped    the program is not part of this build, or no GL context can be created

and prints one table (class, runs, ok, clean errors, crashes, hangs, silent wrong, bad
errors, skipped). Exits 1 when any of crashes, hangs, silent wrong or bad errors is non-zero
(or a case is broken), 0 otherwise.

  hostile_runner.py --bin BUILD/bin --src REPO [--work DIR] [--jobs 2] [--filter REGEX]
                    [--list] [--keep] [--no-memory-limit] [--verbose]
"""
import argparse
import concurrent.futures
import copy
import json
import os
import re
import resource
import shutil
import signal
import struct
import subprocess
import sys
import tempfile
import time
import zlib

RESULTS = ["ok", "clean", "crash", "hang", "wrong", "bad error", "skipped", "broken"]
FAILING = {"crash", "hang", "wrong", "bad error", "broken"}
CRASH_MARKERS = re.compile(r"AddressSanitizer|LeakSanitizer|UndefinedBehaviorSanitizer|runtime error:|"
                           r"terminate called|Assertion .* failed|Segmentation fault|core dumped")
TOOL_USAGE_STATUS = 64  # modrt-hostile-tool: the case itself is broken
# The programs' error exits: 1 (the operation failed), 2 (bad arguments), and CLI11's parse
# errors (CLI11_PARSE returns CLI::Error::get_exit_code(): 100 + the error kind, e.g. 104
# ConversionError, 105 ValidationError, 109 ArgumentMismatch).
CLEAN_STATUS = [1, 2] + list(range(100, 126))


# ---------------------------------------------------------------------------------------
# Generated inputs

class Raw:
    """A JSON token written as is (NaN, Infinity, 1e999, -0): JSON cannot express all of them."""

    def __init__(self, token):
        self.token = str(token)


def dump_json(doc):
    raws = []

    def walk(x):
        if isinstance(x, Raw):
            raws.append(x.token)
            return "\u0000RAW%d\u0000" % (len(raws) - 1)
        if isinstance(x, dict):
            return {k: walk(v) for k, v in x.items()}
        if isinstance(x, list):
            return [walk(v) for v in x]
        return x

    text = json.dumps(walk(doc), indent=1)
    for i, token in enumerate(raws):
        text = text.replace('"\\u0000RAW%d\\u0000"' % i, token)
    return text


def pointer_parts(pointer):
    if pointer == "":
        return []
    if not pointer.startswith("/"):
        raise ValueError("JSON pointer %r must start with /" % pointer)
    return [p.replace("~1", "/").replace("~0", "~") for p in pointer[1:].split("/")]


def json_set(doc, pointer, value):
    parts = pointer_parts(pointer)
    node = doc
    for p in parts[:-1]:
        node = node[int(p)] if isinstance(node, list) else node.setdefault(p, {})
    last = parts[-1]
    if isinstance(node, list):
        if last == "-":
            node.append(value)
        else:
            node[int(last)] = value
    else:
        node[last] = value


def json_delete(doc, pointer):
    parts = pointer_parts(pointer)
    node = doc
    for p in parts[:-1]:
        node = node[int(p)] if isinstance(node, list) else node[p]
    if isinstance(node, list):
        del node[int(parts[-1])]
    else:
        node.pop(parts[-1], None)


def to_json_value(v):
    """Case files write raw tokens as {"raw": "NaN"}; plain JSON values stay as they are."""
    if isinstance(v, dict) and set(v) == {"raw"}:
        return Raw(v["raw"])
    if isinstance(v, dict):
        return {k: to_json_value(x) for k, x in v.items()}
    if isinstance(v, list):
        return [to_json_value(x) for x in v]
    return v


def number(value):
    """A number given as a number or a token: FLT_MAX, -FLT_MAX, nan, inf, 1e-45."""
    tokens = {"FLT_MAX": 3.4028234663852886e38, "-FLT_MAX": -3.4028234663852886e38}
    return tokens[str(value)] if str(value) in tokens else float(value)


def float_bits(value):
    """IEEE binary32 bits of a number (see number()); beyond the float range: +-inf."""
    v = number(value)
    try:
        return struct.pack("<f", v)
    except OverflowError:
        return struct.pack("<f", float("inf") if v > 0 else float("-inf"))


def u32(b, at):
    return struct.unpack_from("<I", b, at)[0]


def put_u32(b, at, v):
    struct.pack_into("<I", b, at, v & 0xFFFFFFFF)


def dictionary_sections(b):
    """(kind, shape, rows, cols, element type, sub-index, payload offset, size, entry offset)."""
    header = u32(b, 12)
    count = u32(b, 96)
    out = []
    for i in range(count):
        e = header + 48 * i
        kind, shape, rows, cols, etype, sub = struct.unpack_from("<6I", b, e)
        offset, size = struct.unpack_from("<2Q", b, e + 24)
        out.append((kind, shape, rows, cols, etype, sub, offset, size, e))
    return out


SECTION_KINDS = {"Ub": 1, "Td_b": 2, "Limp": 3, "Ub_vec": 4, "Ubvol": 5, "sigma_M": 6, "Rb_rlf": 16,
                 "R_straight": 17, "R_left": 18, "R_right": 19, "Trlf_r": 20, "Ur": 21, "Urvol": 22,
                 "Ur_vec": 23}


def reseal_dictionary(b):
    """Recomputes every payload CRC, the section table CRC and the header CRC (dictionary_io.h)."""
    header = u32(b, 12)
    count = u32(b, 96)
    for (_, _, _, _, _, _, offset, size, e) in dictionary_sections(b):
        put_u32(b, e + 40, zlib.crc32(bytes(b[offset:offset + size])))
    put_u32(b, 100, zlib.crc32(bytes(b[header:header + 48 * count])))
    put_u32(b, 108, zlib.crc32(bytes(b[:108])))


def poke_dictionary(b, spec):
    kind = SECTION_KINDS[spec["section"]]
    shape = spec.get("shape", 0)
    for (k, s, rows, cols, etype, sub, offset, size, _) in dictionary_sections(b):
        if k == kind and (s == shape or s == 0xFFFFFFFF):
            if etype != 0:
                raise ValueError("dictionary-poke: section %s is not float32" % spec["section"])
            index = spec.get("index", 0)
            if index < 0:
                index += rows * cols
            if not 0 <= index < rows * cols:
                raise ValueError("dictionary-poke: index %d outside %dx%d" % (index, rows, cols))
            b[offset + 4 * index:offset + 4 * index + 4] = float_bits(spec["value"])
            reseal_dictionary(b)
            return
    raise ValueError("dictionary-poke: no section %s for shape %d" % (spec["section"], shape))


def level_layout(b):
    """Byte offsets into a .modrtlevel (level_io.h): first block's corners, first record's T."""
    blocks, samples, slots, records = u32(b, 28), u32(b, 32), u32(b, 36), u32(b, 40)
    at = 64
    block_bytes = 4 + 4 + 12 + 8 * 24 + 24 + 4 + 4 + 4 * 18  # ... sample_count, f32 albedo[6][3]
    corners = at + 20
    at += blocks * block_bytes
    for _ in range(slots):
        n = u32(b, at + 8)
        at += 12 + 4 * n
    record_values = at + 16 if records else None
    record_count = (u32(b, at + 8) * u32(b, at + 12)) if records else 0
    return {"corners": corners, "record": record_values, "record_values": record_count}


def reseal_level(b):
    put_u32(b, 48, len(b) - 64)
    put_u32(b, 52, (len(b) - 64) >> 32)
    put_u32(b, 56, zlib.crc32(bytes(b[64:])))
    put_u32(b, 60, zlib.crc32(bytes(b[:60])))


def poke_level(b, spec):
    layout = level_layout(b)
    field, index = spec["field"], spec.get("index", 0)
    if field == "record":
        if layout["record"] is None or not 0 <= index < layout["record_values"]:
            raise ValueError("level-poke: no record value %d" % index)
        at = layout["record"] + 4 * index
        b[at:at + 4] = float_bits(spec["value"])
    elif field == "corner":  # f64 corners[8][3] of block 0
        if not 0 <= index < 24:
            raise ValueError("level-poke: corner component %d outside 0..23" % index)
        at = layout["corners"] + 8 * index
        b[at:at + 8] = struct.pack("<d", number(spec["value"]))
    else:
        raise ValueError("level-poke: unknown field %r" % field)
    reseal_level(b)


def corridor_level(blocks):
    """A straight corridor of `blocks` cells along +Z with a light in the first cell."""
    cells = []
    for z in range(blocks):
        missing = []
        if z > 0:
            missing.append("-Z")
        if z + 1 < blocks:
            missing.append("+Z")
        cells.append({"cell": [0, 0, z], "missing": missing})
    return {"format": "modrt-level", "version": 1, "name": "corridor%d" % blocks, "cell_size": 1.0,
            "blocks": cells,
            "lights": [{"position": [0.5, 0.5, 0.5], "radius": 0.05, "color": [1, 1, 1], "intensity": 1.0}]}


def gltf_instances(doc, count, mesh):
    """Adds `count` nodes instancing `mesh` of a glTF (a grid inside the first block)."""
    side = max(1, round(count ** (1.0 / 3.0)))
    new = []
    for i in range(count):
        x, y, z = i % side, (i // side) % side, i // (side * side)
        new.append({"mesh": mesh, "translation": [0.1 + 0.8 * x / side, 0.1 + 0.8 * y / side, 0.1 + 0.8 * z / side],
                    "scale": [0.01, 0.01, 0.01]})
    first = len(doc["nodes"])
    doc["nodes"].extend(new)
    doc["scenes"][doc.get("scene", 0)]["nodes"].extend(range(first, first + count))


def make_input(spec, subst):
    kind = spec["kind"]
    out = subst(spec["out"])
    os.makedirs(os.path.dirname(out), exist_ok=True)
    template = subst(spec["template"]) if "template" in spec else None
    if kind == "json":
        with open(template) as f:
            doc = json.load(f)
        for pointer in spec.get("delete", []):
            json_delete(doc, pointer)
        for pointer, value in spec.get("set", {}).items():
            json_set(doc, pointer, to_json_value(value))
        if "instances" in spec:
            gltf_instances(doc, int(spec["instances"]), int(spec.get("mesh", 0)))
        if "external_buffer" in spec:  # buffer 0's data URI moved to a file beside the output
            uri = doc["buffers"][0]["uri"]
            import base64
            data = base64.b64decode(uri.split(",", 1)[1])
            name = spec["external_buffer"]
            with open(os.path.join(os.path.dirname(out), name), "wb") as f:
                f.write(data)
            doc["buffers"][0]["uri"] = spec.get("uri", name)
        with open(out, "w") as f:
            f.write(dump_json(doc))
    elif kind == "text":
        with open(out, "w") as f:
            f.write(spec["text"])
    elif kind == "corridor":
        with open(out, "w") as f:
            f.write(dump_json(corridor_level(int(spec["blocks"]))))
    elif kind in ("dictionary-poke", "level-poke", "append"):
        with open(template, "rb") as f:
            b = bytearray(f.read())
        if kind == "dictionary-poke":
            poke_dictionary(b, spec)
        elif kind == "level-poke":
            poke_level(b, spec)
        else:
            b.extend(b"\0" * int(spec["bytes"]))
        with open(out, "wb") as f:
            f.write(b)
    elif kind == "mkdir":
        os.makedirs(out, exist_ok=True)
    else:
        raise ValueError("unknown input kind %r" % kind)


# ---------------------------------------------------------------------------------------
# Cases

def substitute(x, values):
    """Replaces {name} placeholders in every string of x; a string that is exactly one
    placeholder of a raw value keeps the value's type (a Raw token in JSON inputs)."""
    if isinstance(x, str):
        m = re.fullmatch(r"\{(\w+)\}", x)
        if m and m.group(1) in values and not isinstance(values[m.group(1)], str):
            return values[m.group(1)]
        return re.sub(r"\{(\w+)\}", lambda m: str(values[m.group(1)]) if m.group(1) in values else m.group(0), x)
    if isinstance(x, dict):
        return {substitute(k, values): substitute(v, values) for k, v in x.items()}
    if isinstance(x, list):
        return [substitute(v, values) for v in x]
    return x


def load_cases(case_dir):
    cases = []
    for name in sorted(os.listdir(case_dir)):
        if not name.endswith(".json"):
            continue
        with open(os.path.join(case_dir, name)) as f:
            doc = json.load(f)
        klass = doc.get("class", name[:-5])
        prefixes = doc.get("prefix", {})
        for c in doc.get("cases", []):
            c = copy.deepcopy(c)
            c.setdefault("class", klass)
            c["_file"] = name
            c["_prefix"] = prefixes
            cases.append(c)
        for g in doc.get("generate", []):
            for field in g["fields"]:
                for value in g["values"]:
                    v = value if isinstance(value, dict) else {"value": value}
                    if "only" in field and v["value"] not in field["only"]:
                        continue
                    if v["value"] in field.get("skip", []):
                        continue
                    own = {"value": v["value"], "json_value": Raw(v["value"])}
                    values = substitute(dict(field), own)  # a field's own entries may use {value}
                    values.update(own)
                    c = substitute(copy.deepcopy(g["case"]), values)
                    c["name"] = "%s/%s=%s" % (g["name"], field["name"], v["value"])
                    c.setdefault("class", g.get("class", klass))
                    alt = v.get("stderr_alt")
                    if alt and "expect" in c and "stderr" in c["expect"]:
                        c["expect"]["stderr"] = "(%s)|(%s)" % (c["expect"]["stderr"], alt)
                    c["_file"] = name
                    c["_prefix"] = prefixes
                    c["_generated"] = True
                    cases.append(c)
    names = [c["name"] for c in cases]
    dup = {n for n in names if names.count(n) > 1}
    if dup:
        raise SystemExit("hostile_runner: duplicate case names: %s" % ", ".join(sorted(dup)))
    return cases


def program_argv(step, prefix, subst, bindir):
    program = step["program"]
    path = os.path.join(bindir, program)
    args = []
    for a in step.get("argv", []):  # a generated field's argv list is spliced in
        a = subst(a)
        args.extend(a if isinstance(a, list) else [a])
    flags = {a.split("=", 1)[0] for a in args if a.startswith("-")}
    pre = []
    for item in prefix.get(program, []):
        item = [subst(a) for a in (item if isinstance(item, list) else [item])]
        if item[0] not in flags:
            pre.extend(item)
    return path, [path] + pre + args


def limit_memory(mb):
    def apply():
        os.setsid()
        if mb:
            resource.setrlimit(resource.RLIMIT_AS, (mb << 20, mb << 20))
    return apply


# Programs whose eglTerminate unloads Mesa's driver: LeakSanitizer then reports Mesa's leaks from
# an unknown module that no suppression can name, so leak checking is off for them under ASan
# (as for ctest's embed_host, tests/CMakeLists.txt); ASan's other checks stay on. The runtime's
# own leaks are checked by test_c_api, which keeps the driver loaded.
UNLOADS_GL_DRIVER = {"modrt-embed-host"}


def run_process(argv, env, cwd, timeout, memory_mb):
    start = time.monotonic()
    proc = subprocess.Popen(argv, stdout=subprocess.PIPE, stderr=subprocess.PIPE, env=env, cwd=cwd,
                            preexec_fn=limit_memory(memory_mb))
    try:
        out, err = proc.communicate(timeout=timeout)
        hung = False
    except subprocess.TimeoutExpired:
        try:
            os.killpg(proc.pid, signal.SIGKILL)
        except ProcessLookupError:
            pass
        out, err = proc.communicate()
        hung = True
    return proc.returncode, out.decode("utf-8", "replace"), err.decode("utf-8", "replace"), hung, \
        time.monotonic() - start


def parse_stats(text):
    stats = {}
    for line in text.splitlines():
        if line.startswith("STATS "):
            parts = line.split()
            fields = dict(p.split("=", 1) for p in parts[2:] if "=" in p)
            stats[parts[1]] = {k: float(v) for k, v in fields.items()}
    return stats


def check_stats(what, s, check):
    """Problems of one output (a STATS line) against a check: finite, >= 0, nonzero, max."""
    problems = []
    if s.get("nonfinite", 0) > 0:
        problems.append("%s: %d non-finite values" % (what, s["nonfinite"]))
    if check.get("nonnegative", True) and s.get("negative", 0) > 0:
        problems.append("%s: %d negative values (min %g)" % (what, s["negative"], s.get("min", 0)))
    if check.get("nonzero") and s.get("nonzero", 0) == 0:
        problems.append("%s: all %d values are zero" % (what, s.get("values", 0)))
    if "max" in check and s.get("max", 0) > check["max"]:
        problems.append("%s: max %g above the plausible bound %g" % (what, s["max"], check["max"]))
    if "min_values" in check and s.get("values", 0) < check["min_values"]:
        problems.append("%s: %d values, expected at least %d" % (what, s.get("values", 0), check["min_values"]))
    return problems


class Runner:
    def __init__(self, args):
        self.args = args
        self.bindir = os.path.abspath(args.bin)
        self.src = os.path.abspath(args.src)
        self.tool = os.path.join(self.bindir, "modrt-hostile-tool")

    def placeholders(self, tmp):
        corpus = os.path.join(self.src, "tests", "fuzz", "corpus")
        return {"bin": self.bindir, "src": self.src, "data": os.path.join(self.src, "data"), "corpus": corpus,
                "inputs": os.path.join(self.src, "tests", "hostile", "inputs"), "tmp": tmp, "tool": self.tool,
                "dict": os.path.join(corpus, "dictionary", "tiny_interfaces.modrt"),
                "dict_no_interfaces": os.path.join(corpus, "dictionary", "tiny_no_interfaces.modrt"),
                "level": os.path.join(corpus, "level_file", "maze11.modrtlevel")}

    def run_case(self, case):
        tmp = tempfile.mkdtemp(prefix="case-", dir=self.args.work)
        try:
            return self._run_case(case, tmp)
        except Exception as e:  # a broken case must not pass quietly
            return {"result": "broken", "detail": "%s: %s" % (type(e).__name__, e), "seconds": 0.0}
        finally:
            if not self.args.keep:
                shutil.rmtree(tmp, ignore_errors=True)

    def _run_case(self, case, tmp):
        values = self.placeholders(tmp)
        subst = lambda s: substitute(s, values)
        expect = case.get("expect", {})
        want = expect.get("result", "either")
        timeout = float(case.get("timeout", 60)) * self.args.timeout_scale
        memory_mb = 0 if self.args.no_memory_limit else int(case.get("memory_mb", 6144))
        env = dict(os.environ)
        env.update({"HOME": os.path.join(tmp, "home"), "MODRT_CACHE_DIR": os.path.join(tmp, "cache"),
                    "XDG_CACHE_HOME": os.path.join(tmp, "xdg")})
        env.setdefault("UBSAN_OPTIONS", "print_stacktrace=1")
        for spec in case.get("inputs", []):
            make_input(spec, subst)
        steps = case.get("steps") or [{"program": case["program"], "argv": case.get("argv", [])}]
        seconds = 0.0
        out = err = ""
        for step in steps:
            path, argv = program_argv(step, case["_prefix"], subst, self.bindir)
            if not os.path.exists(path):
                return {"result": "skipped", "detail": "%s is not built" % step["program"], "seconds": seconds}
            step_env = env
            if step["program"] in UNLOADS_GL_DRIVER and "ASAN_OPTIONS" in env:
                step_env = dict(env, ASAN_OPTIONS=env["ASAN_OPTIONS"] + ":detect_leaks=0")  # the last one wins
            status, out, err, hung, dt = run_process(argv, step_env, tmp, timeout, memory_mb)
            seconds += dt
            cmd = " ".join(argv)
            tail = (err.strip().splitlines() or [""])[-1][:300]
            if hung:
                return {"result": "hang", "detail": "no exit after %.0f s: %s" % (timeout, cmd), "seconds": seconds}
            if status < 0:
                return {"result": "crash", "detail": "signal %s: %s | %s" % (signal.Signals(-status).name, cmd, tail),
                        "seconds": seconds}
            if CRASH_MARKERS.search(err):
                m = CRASH_MARKERS.search(err)
                return {"result": "crash", "detail": "%s (exit %d): %s | %s" % (m.group(0), status, cmd,
                                                                                 err[m.start():m.start() + 300]),
                        "seconds": seconds}
            if status == TOOL_USAGE_STATUS and step["program"] == "modrt-hostile-tool":
                return {"result": "broken", "detail": "tool usage: %s" % tail, "seconds": seconds}
            if status == 77 or (status != 0 and step["program"] == "modrt-demo" and "GL context:" in err):
                return {"result": "skipped", "detail": "no GL context: %s" % tail, "seconds": seconds}
            if status != 0:
                allowed = expect.get("status", CLEAN_STATUS)
                if status not in allowed:
                    return {"result": "crash", "detail": "exit %d (expected %s): %s | %s" % (status, allowed, cmd, tail),
                            "seconds": seconds}
                if want == "ok":
                    return {"result": "bad error", "detail": "valid input refused: %s | %s" % (cmd, tail),
                            "seconds": seconds}
                regex = expect.get("stderr", "")
                if regex and not re.search(regex, err, re.I):
                    return {"result": "bad error", "detail": "stderr does not match /%s/: %s" % (regex, tail),
                            "seconds": seconds}
                if expect.get("stderr_not") and re.search(expect["stderr_not"], err, re.I):
                    return {"result": "bad error", "detail": "stderr matches /%s/: %s" % (expect["stderr_not"], tail),
                            "seconds": seconds}
                if expect.get("stdout_not") and re.search(expect["stdout_not"], out, re.I):
                    return {"result": "bad error",
                            "detail": "error found late: stdout matches /%s/ before %s" % (expect["stdout_not"], tail),
                            "seconds": seconds}
                if expect.get("max_seconds") and seconds > expect["max_seconds"]:
                    return {"result": "bad error", "detail": "error after %.1f s (bound %.0f s): %s" % (
                        seconds, expect["max_seconds"], tail), "seconds": seconds}
                return {"result": "clean", "detail": tail, "seconds": seconds}
        # every step exited 0
        if want == "error":
            return {"result": "wrong", "detail": "accepted (exit 0), expected an error /%s/" % expect.get("stderr", ""),
                    "seconds": seconds}
        problems = []
        if expect.get("stdout") and not re.search(expect["stdout"], out + err, re.I):
            problems.append("output does not match /%s/" % expect["stdout"])
        if expect.get("max_seconds") and seconds > expect["max_seconds"]:
            problems.append("took %.1f s (bound %.0f s)" % (seconds, expect["max_seconds"]))
        stats = parse_stats(out)
        for check in expect.get("stats", []):
            if check["name"] not in stats:
                problems.append("no STATS line %s" % check["name"])
            else:
                problems += check_stats(check["name"], stats[check["name"]], check)
        for check in expect.get("outputs", []):
            path = subst(check["file"])
            if not os.path.exists(path):
                problems.append("%s: not written" % os.path.basename(path))
                continue
            status, sout, serr, hung, _ = run_process([self.tool, "stats", path], env, tmp, 60, 0)
            s = parse_stats(sout).get(path)
            if status != 0 or s is None:
                problems.append("%s: unreadable: %s" % (os.path.basename(path), serr.strip()[-200:]))
                continue
            problems += check_stats(os.path.basename(path), s, check)
        if problems:
            return {"result": "wrong", "detail": "; ".join(problems), "seconds": seconds}
        return {"result": "ok", "detail": "", "seconds": seconds}


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--bin", required=True, help="the build's bin directory (modrt-level, modrt-hostile-tool, ...)")
    ap.add_argument("--src", default=os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", ".."))
    ap.add_argument("--cases", help="case directory (default: tests/hostile/cases)")
    ap.add_argument("--work", help="where the per-case temporary directories go (default: system temp)")
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--filter", help="run only cases whose name or class matches this regex")
    ap.add_argument("--list", action="store_true", help="list the cases and exit")
    ap.add_argument("--keep", action="store_true", help="keep the per-case directories")
    ap.add_argument("--no-memory-limit", action="store_true",
                    help="no RLIMIT_AS per case (sanitizer builds reserve terabytes of address space)")
    ap.add_argument("--timeout-scale", type=float, default=1.0, help="multiply every case's timeout")
    ap.add_argument("--results", help="write every case's result as JSON here")
    ap.add_argument("--verbose", action="store_true", help="print every case, not only failures")
    args = ap.parse_args()
    case_dir = args.cases or os.path.join(os.path.abspath(args.src), "tests", "hostile", "cases")
    cases = load_cases(case_dir)
    if args.filter:
        cases = [c for c in cases if re.search(args.filter, c["name"]) or re.search(args.filter, c["class"])]
    if args.list:
        for c in cases:
            print("%-22s %s" % (c["class"], c["name"]))
        print("%d cases" % len(cases))
        return 0
    if args.work:
        os.makedirs(args.work, exist_ok=True)
    if os.environ.get("ASAN_OPTIONS") is not None and not args.no_memory_limit:
        args.no_memory_limit = True
    runner = Runner(args)
    start = time.monotonic()
    results = {}
    with concurrent.futures.ThreadPoolExecutor(max_workers=max(1, args.jobs)) as pool:
        futures = {pool.submit(runner.run_case, c): c for c in cases}
        for fut in concurrent.futures.as_completed(futures):
            c = futures[fut]
            r = fut.result()
            results[c["name"]] = dict(r, **{"class": c["class"]})
            if r["result"] in FAILING or args.verbose:
                print("%-9s %-50s %5.1fs  %s" % (r["result"].upper(), c["name"], r["seconds"], r["detail"]),
                      flush=True)
    total = time.monotonic() - start

    classes = []
    for c in cases:
        if c["class"] not in classes:
            classes.append(c["class"])
    header = ["class", "runs", "ok", "clean errors", "crashes", "hangs", "silent wrong", "bad errors", "skipped"]
    keys = ["ok", "clean", "crash", "hang", "wrong", "bad error", "skipped"]
    rows = []
    sums = [0] * (len(keys) + 1)
    for k in classes:
        rs = [results[c["name"]]["result"] for c in cases if c["class"] == k]
        row = [len(rs)] + [rs.count(key) + (rs.count("broken") if key == "bad error" else 0) for key in keys]
        sums = [a + b for a, b in zip(sums, row)]
        rows.append([k] + row)
    rows.append(["total"] + sums)
    print()
    print("| " + " | ".join(header) + " |")
    print("|" + "---|" * len(header))
    for r in rows:
        print("| " + " | ".join(str(x) for x in r) + " |")
    failed = [c["name"] for c in cases if results[c["name"]]["result"] in FAILING]
    print("\n%d cases in %.0f s (%d jobs); %d failed%s" % (len(cases), total, args.jobs, len(failed),
                                                          "" if not failed else ":"))
    for n in sorted(failed):
        print("  %-9s %s" % (results[n]["result"], n))
    if args.results:
        with open(args.results, "w") as f:
            json.dump(results, f, indent=1, sort_keys=True)
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
