// SPDX-License-Identifier: MIT
/* An out-of-tree consumer of the installed modrt runtime (scripts/test-install.sh): plain C,
 * built against the installed package (find_package(modrt) or pkg-config), checks the version,
 * an error path, and, given a dictionary and a level, loads the level from memory (as an app
 * does from its bundle), lights it on the CPU and checks the atlas.
 *
 * Then multi-bounce (and the bounce count changed per update), vector irradiance, the probe
 * volume (and the probe cell a shader samples it with) and, given a .modrtdrt file, a clutter
 * object with its texels' lightmap cells (more_capabilities).
 *
 *   modrt_consumer [dictionary.modrt level.modrtlevel [clutter.modrtdrt]]
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <modrt/modrt.h>

#include "consumer_check.h"

static unsigned char* read_all(const char* path, size_t* size) {
  FILE* f = fopen(path, "rb");
  if (!f) return NULL;
  fseek(f, 0, SEEK_END);
  long n = ftell(f);
  rewind(f);
  unsigned char* data = n > 0 ? malloc((size_t)n) : NULL;
  if (data && fread(data, 1, (size_t)n, f) != (size_t)n) {
    free(data);
    data = NULL;
  }
  fclose(f);
  *size = (size_t)n;
  return data;
}

static double mean_of(const float* v, size_t n) {
  double sum = 0.0;
  for (size_t i = 0; i < n; ++i) sum += v[i];
  return n ? sum / (double)n : 0.0;
}

static int all_finite(const float* v, size_t n, const char* what) {
  for (size_t i = 0; i < n; ++i)
    if (!isfinite(v[i])) {
      fprintf(stderr, "%s value %zu is not finite\n", what, i);
      return 0;
    }
  return 1;
}

/* What the demo does beyond one bounce, from plain C on the CPU context `ctx` (default options,
 * lit by the sun, updated once): multi-bounce, vector irradiance for normal-mapped surfaces, the
 * probe volume, and (given a .modrtdrt file) a clutter object. */
static int more_capabilities(modrt_dictionary* dict, modrt_level* level, modrt_context* ctx,
                             const modrt_sizes* sizes, const char* clutter_path) {
  const size_t n3 = sizes->lightmap;
  float* one = malloc(n3 * sizeof *one);
  float* more = malloc(n3 * sizeof *more);
  float* converged = malloc(n3 * sizeof *converged);
  float* ld = malloc(n3 * sizeof *ld);
  float* vec = malloc(4 * n3 * sizeof *vec);
  if (!one || !more || !converged || !ld || !vec) return 1;
  CHECK(modrt_context_read_ld(ctx, ld, n3));

  /* The default bounces solve the whole bounce series (MODRT_BOUNCES_CONVERGED, since 0.4);
   * 0 bounces on the same context give the one-bounce lightmap. */
  uint32_t default_bounces = 0;
  CHECK(modrt_context_get_bounces(ctx, &default_bounces));
  if (default_bounces != MODRT_BOUNCES_CONVERGED) {
    fprintf(stderr, "bounces: the default is %u, expected MODRT_BOUNCES_CONVERGED\n", default_bounces);
    return 1;
  }
  CHECK(modrt_context_read_lightmap(ctx, converged, n3));
  CHECK(modrt_context_set_bounces(ctx, 0));
  CHECK(modrt_context_update(ctx));
  CHECK(modrt_context_read_lightmap(ctx, one, n3));

  /* Multi-bounce: four feedback steps per update, with vector irradiance. More light, never
   * past the bound max(ld) / (1 - max albedo) of the fed-back light. */
  modrt_context_options options;
  modrt_context_options_init(&options);
  options.shadows = 0;
  options.bounces = 4;
  options.vector_irradiance = 1;
  modrt_context* bounced = NULL;
  CHECK(modrt_context_create(dict, level, &options, NULL, &bounced));
  CHECK(modrt_context_set_ld(bounced, ld, n3));
  CHECK(modrt_context_update(bounced));
  CHECK(modrt_context_read_lightmap(bounced, more, n3));
  float ld_max = 0.0f, lm_max = 0.0f;
  for (size_t i = 0; i < n3; ++i) {
    if (ld[i] > ld_max) ld_max = ld[i];
    if (more[i] > lm_max) lm_max = more[i];
  }
  float conv_max = 0.0f;
  for (size_t i = 0; i < n3; ++i)
    if (converged[i] > conv_max) conv_max = converged[i];
  const double m1 = mean_of(one, n3), m5 = mean_of(more, n3), mc = mean_of(converged, n3);
  printf("multi-bounce: mean lightmap %g with one bounce, %g with 4 more, %g converged (max %g, bound %g)\n",
         m1, m5, mc, conv_max, ld_max / (1.0 - options.max_albedo));
  if (!all_finite(more, n3, "multi-bounce lightmap") || !all_finite(converged, n3, "converged lightmap") ||
      !(m5 > m1) || !(mc > m5) || !(lm_max <= ld_max / (1.0 - options.max_albedo)) ||
      !(conv_max <= ld_max / (1.0 - options.max_albedo))) {
    fprintf(stderr, "multi-bounce: expected more light with each bounce, the series within the bound\n");
    return 1;
  }

  /* Vector irradiance: four OHLSH coefficients per sample in its face frame. At the unshaded
   * normal (0, 0, 1) they give back the scalar lightmap (a normal map perturbs the normal):
   * E(n) / pi = a0 Y0 + a1 Y1(n) + a2 Y2(n) + a3 Y3(n), Y0 = 0.2821, Y2(0, 0, 1) = 0.4886.
   * Four coefficients fit the hemisphere only roughly: core's test_level holds it to 15 % on
   * the small test dictionary; the tiny fuzz-seed dictionary here gives 21 %, held to 30 %. */
  CHECK(modrt_context_read_vector_lightmap(bounced, vec, 4 * n3));
  double num = 0.0, den = 0.0;
  for (size_t s = 0; s < n3 / 3; ++s)
    for (int c = 0; c < 3; ++c) {
      const double flat = 0.28209479 * vec[3 * (4 * s + 0) + c] + 0.48860251 * vec[3 * (4 * s + 2) + c];
      num += (flat - more[3 * s + c]) * (flat - more[3 * s + c]);
      den += (double)more[3 * s + c] * more[3 * s + c];
    }
  const double flat_error = den > 0.0 ? sqrt(num / den) : INFINITY;
  printf("vector irradiance at the unshaded normal vs the lightmap: rel L2 %.3g\n", flat_error);
  if (!all_finite(vec, 4 * n3, "vector irradiance") || !(flat_error < 0.30)) {
    fprintf(stderr, "vector irradiance: its flat-normal value is far from the lightmap\n");
    return 1;
  }

  /* Probes: the whole volume for the app's own GPU sampling, and one point query, which must
   * agree with the volume at a probe's position. */
  if (sizes->probes > 0) {
    float* probes = malloc(sizes->probes * sizeof *probes);
    float* where = malloc(sizes->probes / 9 * sizeof *where);
    if (!probes || !where) return 1;
    CHECK(modrt_context_read_probes(bounced, MODRT_PROBE_IRRADIANCE_OVER_PI, probes, sizes->probes));
    CHECK(modrt_context_get_probe_positions(bounced, where, sizes->probes / 9));
    float at[27];
    const size_t p = sizes->probes / 27 / 2; /* a probe in the middle of the volume */
    CHECK(modrt_context_probe_sh(bounced, &where[3 * p], MODRT_PROBE_IRRADIANCE_OVER_PI, at));
    double worst = 0.0, scale = 0.0;
    for (int k = 0; k < 27; ++k) {
      const double d = fabs((double)at[k] - probes[27 * p + (size_t)k]);
      if (d > worst) worst = d;
      if (fabs(probes[27 * p + (size_t)k]) > scale) scale = fabs(probes[27 * p + (size_t)k]);
    }
    printf("probes: %zu, E/pi DC at probe %zu = %g; point query there differs by %g\n", sizes->probes / 27, p,
           probes[27 * p], worst);
    if (!all_finite(probes, sizes->probes, "probes") || !(probes[27 * p] > 0.0f) ||
        !(worst <= 1e-4 * scale)) {
      fprintf(stderr, "probes: expected light at the middle probe and the point query to match the volume\n");
      return 1;
    }
    /* The probe cell of a point between probes, as a shader samples the volume: its 8 probes
     * mixed with their weights are the point query (the tiny dictionary has one probe per
     * block, so the weights are 0 here; test_c_api checks a 2 x 2 x 2 grid). */
    const size_t q = p + 1 < sizes->probes / 27 ? p + 1 : p - 1;
    float between[3];
    for (int a = 0; a < 3; ++a) between[a] = 0.5f * (where[3 * p + (size_t)a] + where[3 * q + (size_t)a]);
    modrt_probe_cell cell = {sizeof(modrt_probe_cell)};
    CHECK(modrt_context_locate_probe(bounced, between, &cell));
    CHECK(modrt_context_probe_sh(bounced, between, MODRT_PROBE_IRRADIANCE_OVER_PI, at));
    double mixed_worst = 0.0, weights = 0.0;
    for (int c = 0; c < 8; ++c) weights += cell.corner_weight[c];
    for (int k = 0; k < 27; ++k) {
      double mixed = 0.0;
      for (int c = 0; c < 8; ++c)
        mixed += cell.corner_weight[c] * probes[27 * (size_t)cell.probe[c] + (size_t)k];
      if (fabs(mixed - at[k]) > mixed_worst) mixed_worst = fabs(mixed - at[k]);
    }
    printf(
        "probe cell: block %u, lower (%d, %d, %d), weights (%.3f, %.3f, %.3f); mixed probes differ by %g\n",
        cell.block, cell.lower[0], cell.lower[1], cell.lower[2], cell.weight[0], cell.weight[1],
        cell.weight[2], mixed_worst);
    if (!(fabs(weights - 1.0) < 1e-5) || !(mixed_worst <= 1e-4 * scale) || cell.grid != sizes->probe_grid) {
      fprintf(stderr, "probe cell: its 8 probes and weights must give the point query\n");
      return 1;
    }
    modrt_probe_cell unsized = {0};
    if (modrt_context_locate_probe(bounced, between, &unsized) == MODRT_OK ||
        !strstr(modrt_last_error(), "out.struct_size")) {
      fprintf(stderr, "probe cell: a struct_size of 0 must be refused naming out.struct_size\n");
      return 1;
    }
    free(probes);
    free(where);
  }

  /* The bounce count per update, on the same context: 0 steps give the one-bounce lightmap,
   * 4 again the multi-bounce one bit for bit; 65 is refused naming `bounces`, nothing changes. */
  float* check = malloc(n3 * sizeof *check);
  if (!check) return 1;
  uint32_t steps = 99;
  CHECK(modrt_context_get_bounces(bounced, &steps));
  if (steps != 4) {
    fprintf(stderr, "bounces: the context was created with 4, get_bounces says %u\n", steps);
    return 1;
  }
  CHECK(modrt_context_set_bounces(bounced, 0));
  CHECK(modrt_context_update(bounced));
  CHECK(modrt_context_read_lightmap(bounced, check, n3));
  double d_one = 0.0, n_one = 0.0;
  for (size_t i = 0; i < n3; ++i) {
    d_one += ((double)check[i] - one[i]) * ((double)check[i] - one[i]);
    n_one += (double)one[i] * one[i];
  }
  if (modrt_context_set_bounces(bounced, 65) == MODRT_OK || !strstr(modrt_last_error(), "bounces 65")) {
    fprintf(stderr, "bounces: 65 must be refused naming bounces\n");
    return 1;
  }
  printf("bounces 65 refused: %s\n", modrt_last_error());
  CHECK(modrt_context_get_bounces(bounced, &steps));
  CHECK(modrt_context_set_bounces(bounced, 4));
  CHECK(modrt_context_update(bounced));
  CHECK(modrt_context_read_lightmap(bounced, check, n3));
  const int same_more = memcmp(check, more, n3 * sizeof *check) == 0;
  printf("set_bounces: 0 steps vs one bounce rel L2 %.3g; 4 steps again %s\n", sqrt(d_one / n_one),
         same_more ? "identical" : "DIFFERENT");
  if (steps != 0 || !(sqrt(d_one / n_one) < 1e-5) || !same_more) {
    fprintf(stderr, "bounces: set_bounces must give 0 and 4 steps on the same context\n");
    return 1;
  }
  free(check);

  /* The converged multi-bounce and its statistics; then the camera skip from an eye outside the
   * level (which sees every block: nothing is hidden). */
  CHECK(modrt_context_set_bounces(bounced, MODRT_BOUNCES_CONVERGED));
  CHECK(modrt_context_update(bounced));
  modrt_solve_stats solve;
  memset(&solve, 0, sizeof solve);
  solve.struct_size = sizeof solve;
  CHECK(modrt_context_get_solve_stats(bounced, &solve));
  printf("converged: %u iterations, error bound %.3g, spectral radius %.3g\n", solve.last_iterations,
         (double)solve.last_error_bound, solve.spectral_radius);
  if (solve.solves != 1 || !solve.converged || !(solve.last_error_bound <= 1e-3f) ||
      !(solve.spectral_radius > 0.0 && solve.spectral_radius < 1.0)) {
    fprintf(stderr, "converged: expected one converged solve within 1e-3 and a radius below 1\n");
    return 1;
  }
  /* The same solve as the default context's. */
  CHECK(modrt_context_read_lightmap(bounced, more, n3));
  double d_conv = 0.0, n_conv = 0.0;
  for (size_t i = 0; i < n3; ++i) {
    d_conv += ((double)more[i] - converged[i]) * ((double)more[i] - converged[i]);
    n_conv += (double)converged[i] * converged[i];
  }
  if (!(sqrt(d_conv / n_conv) < 1e-5)) {
    fprintf(stderr, "converged: set_bounces(MODRT_BOUNCES_CONVERGED) differs from the default by rel L2 %g\n",
            sqrt(d_conv / n_conv));
    return 1;
  }
  const float view_projection[16] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
  const float far_eye[3] = {-1e6f, -1e6f, -1e6f};
  CHECK(modrt_context_set_camera(bounced, view_projection, far_eye));
  for (size_t i = 0; i < n3; ++i) ld[i] *= 0.5f;
  CHECK(modrt_context_set_ld(bounced, ld, n3));
  CHECK(modrt_context_update(bounced));
  modrt_skip_stats skipped;
  memset(&skipped, 0, sizeof skipped);
  skipped.struct_size = sizeof skipped;
  CHECK(modrt_context_get_skip_stats(bounced, &skipped));
  if (skipped.tiles_hidden != 0) {
    fprintf(stderr, "camera skip: an eye outside the level must see every block\n");
    return 1;
  }
  CHECK(modrt_context_set_visible_blocks(bounced, NULL, 0)); /* off again */
  CHECK(modrt_context_set_bounces(bounced, 4));              /* clutter takes feedback steps */

  /* A clutter object: its operators from a file (modrt-demo --save-clutter writes them), its
   * light set by the app, bad light refused by name, its lightmap never negative, each texel's
   * lightmap cell on its object's grid (for the app's clutter mesh UVs). */
  if (clutter_path) {
    modrt_clutter* clutter = NULL;
    CHECK(modrt_clutter_load_file(clutter_path, NULL, &clutter));
    modrt_clutter_info ci = {sizeof(modrt_clutter_info)};
    CHECK(modrt_clutter_get_info(clutter, &ci));
    modrt_clutter_cell* cells = malloc(((size_t)ci.texel_count + 1) * sizeof *cells);
    if (!cells) return 1;
    CHECK(modrt_clutter_get_texel_cells(clutter, cells, ci.texel_count));
    for (uint32_t t = 0; t < ci.texel_count; ++t) {
      const modrt_clutter_cell* x = &cells[t];
      if (x->object >= ci.object_count || x->res == 0 || x->u >= x->res || x->v >= x->res ||
          (t > 0 && x->object < cells[t - 1].object)) {
        fprintf(stderr, "clutter: texel %u has cell (%u, %u) of a %u grid on object %u\n", t, x->u, x->v,
                x->res, x->object);
        return 1;
      }
      for (uint32_t o = 0; o < t; ++o)
        if (cells[o].object == x->object && cells[o].face == x->face && cells[o].u == x->u &&
            cells[o].v == x->v) {
          fprintf(stderr, "clutter: texels %u and %u share a cell\n", o, t);
          return 1;
        }
    }
    if (ci.texel_count > 0)
      printf("clutter cells: texel 0 at (%u, %u) of %u x %u on face %u of object %u\n", cells[0].u,
             cells[0].v, cells[0].res, cells[0].res, cells[0].face, cells[0].object);
    if (modrt_clutter_get_texel_cells(clutter, cells, (size_t)ci.texel_count + 1) == MODRT_OK ||
        !strstr(modrt_last_error(), "out has")) {
      fprintf(stderr, "clutter: a wrong cell count must be refused naming out\n");
      return 1;
    }
    free(cells);
    CHECK(modrt_context_set_clutter(bounced, clutter));
    modrt_clutter_destroy(clutter); /* the context keeps its reference */
    float* cld = malloc(3 * (size_t)ci.texel_count * sizeof *cld);
    float* clm = malloc(3 * (size_t)ci.texel_count * sizeof *clm);
    if (!cld || !clm) return 1;
    for (size_t i = 0; i < 3 * (size_t)ci.texel_count; ++i) cld[i] = 0.5f;
    cld[0] = NAN; /* refused, naming the value; nothing changes */
    if (modrt_context_set_clutter_light(bounced, cld, NULL, 3 * (size_t)ci.texel_count) == MODRT_OK) {
      fprintf(stderr, "clutter light with NaN was accepted\n");
      return 1;
    }
    printf("NaN clutter light refused: %s\n", modrt_last_error());
    cld[0] = 0.5f;
    CHECK(modrt_context_set_clutter_light(bounced, cld, NULL, 3 * (size_t)ci.texel_count));
    CHECK(modrt_context_update(bounced));
    CHECK(modrt_context_read_clutter_lightmap(bounced, clm, 3 * (size_t)ci.texel_count));
    double cmin = INFINITY;
    for (size_t i = 0; i < 3 * (size_t)ci.texel_count; ++i)
      if (clm[i] < cmin) cmin = clm[i];
    printf("clutter: %u objects, %u texels, mean clutter lightmap %g, min %g\n", ci.object_count,
           ci.texel_count, mean_of(clm, 3 * (size_t)ci.texel_count), cmin);
    if (!all_finite(clm, 3 * (size_t)ci.texel_count, "clutter lightmap") || cmin < 0.0) {
      fprintf(stderr, "clutter: the clutter lightmap must be finite and never negative\n");
      return 1;
    }
    free(cld);
    free(clm);
  }
  modrt_context_destroy(bounced);
  free(one);
  free(more);
  free(converged);
  free(ld);
  free(vec);
  return 0;
}

int main(int argc, char** argv) {
  printf("modrt %s\n", modrt_version_string());
  if (modrt_version() != MODRT_VERSION) {
    fprintf(stderr, "header version %d, library version %u\n", MODRT_VERSION, modrt_version());
    return 1;
  }
  /* Bad bytes are a named error, not a crash. */
  const unsigned char junk[16] = {'n', 'o', 't', ' ', 'a', ' ', 'l', 'e', 'v', 'e', 'l'};
  modrt_level* bad = NULL;
  modrt_status s = modrt_level_load_memory(junk, sizeof junk, "junk.modrtlevel", NULL, &bad);
  if (s != MODRT_ERROR_FORMAT || bad != NULL || modrt_last_error()[0] == '\0') {
    fprintf(stderr, "junk level: expected MODRT_ERROR_FORMAT, got %s (%s)\n", modrt_status_name(s),
            modrt_last_error());
    return 1;
  }
  printf("junk level refused: %s\n", modrt_last_error());
  if (argc < 3) return 0;

  modrt_dictionary* dict = NULL;
  CHECK(modrt_dictionary_load_file(argv[1], NULL, &dict));
  size_t size = 0;
  unsigned char* bytes = read_all(argv[2], &size);
  if (!bytes) {
    fprintf(stderr, "cannot read %s\n", argv[2]);
    return 1;
  }
  modrt_level* level = NULL;
  CHECK(modrt_level_load_memory(bytes, size, argv[2], NULL, &level));
  free(bytes); /* the level keeps no reference to the bytes */
  modrt_level_info info = {sizeof(modrt_level_info)};
  CHECK(modrt_level_get_info(level, &info));

  /* Lightmap coordinates for the app's own mesh: a floor quad over the whole level, in an
   * interleaved vertex buffer (position, normal, uv), cut at block boundaries. */
  {
    const float y = info.bounds_min[1];
    const float x0 = info.bounds_min[0], x1 = info.bounds_max[0], z0 = info.bounds_min[2],
                z1 = info.bounds_max[2];
    const float vb[4][8] = {{x0, y, z0, 0, 1, 0, 0, 0},
                            {x1, y, z0, 0, 1, 0, 1, 0},
                            {x1, y, z1, 0, 1, 0, 1, 1},
                            {x0, y, z1, 0, 1, 0, 0, 1}};
    const uint32_t indices[6] = {0, 2, 1, 0, 3, 2};
    modrt_mesh_input mesh;
    modrt_mesh_input_init(&mesh);
    mesh.positions = &vb[0][0];
    mesh.position_stride = sizeof vb[0];
    mesh.normals = &vb[0][3];
    mesh.normal_stride = sizeof vb[0];
    mesh.vertex_count = 4;
    mesh.indices = indices;
    mesh.index_count = 6;
    size_t bound = 0, written = 0;
    CHECK(modrt_level_map_mesh_bound(level, &mesh, &bound));
    modrt_mapped_corner* corners = malloc(bound * sizeof *corners);
    modrt_mesh_map_stats stats = {sizeof(modrt_mesh_map_stats)};
    CHECK(modrt_level_map_mesh(level, &mesh, corners, bound, &written, &stats));
    for (size_t i = 0; i < written; ++i)
      if (!(corners[i].lightmap[0] >= 0.0f && corners[i].lightmap[0] <= (float)info.atlas_width &&
            corners[i].lightmap[1] >= 0.0f && corners[i].lightmap[1] <= (float)info.atlas_height)) {
        fprintf(stderr, "mapped corner %zu: lightmap (%g, %g) outside the atlas\n", i, corners[i].lightmap[0],
                corners[i].lightmap[1]);
        return 1;
      }
    free(corners);
    printf("floor quad: %zu triangles mapped to %zu (%zu cut at block boundaries)\n", stats.triangles,
           written / 3, stats.split_triangles);
    if (written != bound || stats.split_triangles == 0) {
      fprintf(stderr, "expected the floor quad cut into the bound's %zu corners, got %zu\n", bound, written);
      return 1;
    }
    /* A NaN position is named. */
    float bad[4][8];
    memcpy(bad, vb, sizeof bad);
    bad[1][0] = NAN;
    mesh.positions = &bad[0][0];
    s = modrt_level_map_mesh_bound(level, &mesh, &bound);
    if (s != MODRT_ERROR_NON_FINITE || !strstr(modrt_last_error(), "positions[1]")) {
      fprintf(stderr, "NaN position: expected MODRT_ERROR_NON_FINITE naming positions[1], got %s (%s)\n",
              modrt_status_name(s), modrt_last_error());
      return 1;
    }
  }

  modrt_context_options options;
  modrt_context_options_init(&options);
  options.shadows = 0;
  modrt_context* ctx = NULL;
  CHECK(modrt_context_create(dict, level, &options, NULL, &ctx));
  modrt_sizes sizes = {sizeof(modrt_sizes)};
  CHECK(modrt_context_get_sizes(ctx, &sizes));
  /* The lights reflect off the level's own per-face albedo. The app computes a sun's ld itself
   * from the level's samples (ld = albedo E / pi, E = I max(0, -n.dir) without shadows) and
   * gets what modrt_context_set_lights computes. */
  const size_t n = info.sample_count;
  modrt_level_sample* smp = malloc(n * sizeof *smp);
  float* albedo = malloc(3 * n * sizeof *albedo);
  float* ld_app = malloc(3 * n * sizeof *ld_app);
  float* ld_ctx = malloc(3 * n * sizeof *ld_ctx);
  if (!smp || !albedo || !ld_app || !ld_ctx) return 1;
  CHECK(modrt_level_get_samples(level, smp, n));
  CHECK(modrt_level_get_albedo(level, albedo, 3 * n));
  modrt_light sun;
  modrt_light_init(&sun);
  sun.type = MODRT_LIGHT_DIRECTIONAL;
  const float dir_len = sqrtf(0.3f * 0.3f + 1.0f + 0.2f * 0.2f);
  sun.direction[0] = 0.3f / dir_len, sun.direction[1] = -1.0f / dir_len, sun.direction[2] = 0.2f / dir_len;
  sun.color[0] = sun.color[1] = sun.color[2] = 1.0f;
  sun.intensity = 2.0f;
  for (size_t i = 0; i < n; ++i) {
    float cosine = -(smp[i].normal[0] * sun.direction[0] + smp[i].normal[1] * sun.direction[1] +
                     smp[i].normal[2] * sun.direction[2]);
    if (cosine < 0.0f) cosine = 0.0f;
    for (int c = 0; c < 3; ++c) ld_app[3 * i + c] = albedo[3 * i + c] * sun.intensity * cosine / 3.14159265f;
  }
  CHECK(modrt_context_set_lights(ctx, &sun, 1));
  CHECK(modrt_context_read_ld(ctx, ld_ctx, 3 * n));
  double worst = 0.0, peak = 0.0;
  for (size_t i = 0; i < 3 * n; ++i) {
    const double d = fabs((double)ld_app[i] - (double)ld_ctx[i]);
    if (d > worst) worst = d;
    if (ld_app[i] > peak) peak = ld_app[i];
  }
  printf("sun ld from the level's samples: max difference %g of %g from set_lights\n", worst, peak);
  if (!(peak > 0.0) || !(worst <= 1e-5 * peak)) {
    fprintf(stderr, "the app's ld differs from set_lights' by %g (peak %g)\n", worst, peak);
    return 1;
  }
  CHECK(modrt_context_set_ld(ctx, ld_app, 3 * n));
  free(smp);
  free(albedo);
  free(ld_app);
  free(ld_ctx);
  CHECK(modrt_context_update(ctx));
  const float* atlas = NULL;
  size_t count = 0;
  CHECK(modrt_context_get_atlas_data(ctx, &atlas, &count));
  double sum = 0.0;
  for (size_t i = 0; i < count; ++i) {
    if (!isfinite(atlas[i])) {
      fprintf(stderr, "atlas value %zu is not finite\n", i);
      return 1;
    }
    sum += atlas[i];
  }
  printf("%s: %u blocks, %u samples, atlas %ux%u, mean atlas value %g (%s)\n", argv[2], info.block_count,
         info.sample_count, sizes.atlas_width, sizes.atlas_height, sum / (double)count,
         modrt_context_description(ctx));
  if (!(sum > 0.0)) {
    fprintf(stderr, "the lit atlas is black\n");
    return 1;
  }
  const int extra = more_capabilities(dict, level, ctx, &sizes, argc > 3 ? argv[3] : NULL);
  modrt_context_destroy(ctx);
  modrt_level_destroy(level);
  modrt_dictionary_destroy(dict);
  return extra;
}
