// SPDX-License-Identifier: MIT
/* modrt — the embeddable runtime's C API (libmodrt_runtime; docs/embedding.md is the tour).
 *
 * An app ships a dictionary (.modrt, from modrt-bake) and a built level (.modrtlevel, from
 * modrt-level --save) in its bundle, loads both from memory or from a file, creates a CPU or
 * OpenGL ES context for the level, and every frame sets the light (point / spot / directional
 * lights, or a raw ld signal), calls modrt_context_update, and reads the result: the GL texture
 * name of the lightmap atlas (GLES), the atlas / lightmap floats (CPU or GLES), and SH9 probes
 * at any position.
 *
 * Errors. Every function that can fail returns a modrt_status; MODRT_OK is 0. On failure the
 * message naming the problem (file, field, index, value) is kept per thread and returned by
 * modrt_last_error() until the next failing call on that thread. No C++ exception leaves
 * the library (std::bad_alloc becomes MODRT_ERROR_OUT_OF_MEMORY). A failed call changes
 * nothing (outputs are written only on success).
 *
 * Thread safety.
 *   - modrt_dictionary and modrt_level are immutable after loading: any number of contexts
 *     on any threads may use them at once. Their reference counts are atomic, so destroying
 *     a handle on one thread while a context created from it lives on another is safe (the
 *     data lives until the last context using it is destroyed).
 *   - A modrt_context is not thread-safe: use it from one thread at a time. Different
 *     contexts may run on different threads at the same time.
 *   - A GLES context must be used (created, updated, queried, destroyed) with the same GL
 *     context current on the calling thread as at its creation.
 *   - modrt_last_error() is per thread.
 *
 * Structs. Every struct the caller passes, in or out, starts with `uint32_t struct_size`, which
 * the caller sets to sizeof(the struct) (the *_init functions do, or `= {sizeof(T)}` in C), so
 * that later versions can add fields at the end and tell which layout a caller was built with.
 * A struct that grew keeps accepting its earlier layouts: modrt_context_options and
 * modrt_timings of version 0.2 (without the fields marked "since 0.3") are read or written up
 * to their struct_size, and the missing input fields take their defaults. Any other
 * struct_size is MODRT_ERROR_INVALID_ARGUMENT, naming the argument and the size expected. The records of an
 * array the library fills (modrt_mapped_corner) have no struct_size: their layout is this header's, and a
 * later layout comes with a new function.
 *
 * Memory. Loading and context creation allocate; the per-frame calls (set_lights, set_ld,
 * update, the queries and reads) do not allocate (outside an error message on failure), except
 * the first converged update (MODRT_BOUNCES_CONVERGED, the default) after creation and after
 * the albedo or the clutter changed, which builds the solve's reduced operators: update once
 * at load time to take that cost there. The
 * allocator passed at creation receives the allocations the runtime layer makes for the
 * handle (see modrt_allocator for the exact extent).
 */
#ifndef MODRT_MODRT_H
#define MODRT_MODRT_H

#include <stddef.h>
#include <stdint.h>

#if defined(_WIN32) && defined(MODRT_BUILDING_RUNTIME)
#define MODRT_API __declspec(dllexport)
#elif defined(__GNUC__)
#define MODRT_API __attribute__((visibility("default")))
#else
#define MODRT_API
#endif

#ifdef __cplusplus
extern "C" {
#endif

#define MODRT_VERSION_MAJOR 0
#define MODRT_VERSION_MINOR 3
#define MODRT_VERSION_PATCH 0
/* The header's version as one number; compare with modrt_version() at run time. */
#define MODRT_VERSION ((MODRT_VERSION_MAJOR << 16) | (MODRT_VERSION_MINOR << 8) | MODRT_VERSION_PATCH)

typedef enum modrt_status {
  MODRT_OK = 0,
  MODRT_ERROR_INVALID_ARGUMENT = 1, /* null handle or pointer, wrong count, bad option or light */
  MODRT_ERROR_IO = 2,               /* a file could not be opened or read */
  MODRT_ERROR_FORMAT = 3,           /* malformed bytes: bad magic, truncated, inconsistent sizes */
  MODRT_ERROR_VERSION_MISMATCH = 4, /* written by another format version: re-bake / rebuild */
  MODRT_ERROR_CHECKSUM_MISMATCH = 5,
  MODRT_ERROR_NON_FINITE = 6,     /* NaN or Inf (in a file or in ld) */
  MODRT_ERROR_RESOURCE_LIMIT = 7, /* larger than a size limit */
  MODRT_ERROR_OUT_OF_MEMORY = 8,  /* the allocator (or operator new) failed */
  MODRT_ERROR_UNSUPPORTED = 9,    /* not available: no probes, CPU context asked for a texture,
                                     GLES not built, no GL loader ... */
  MODRT_ERROR_MISMATCH = 10,      /* the level was not built against this dictionary */
  MODRT_ERROR_GL = 11,            /* the GL context failed: missing entry points, shader, GL error */
  MODRT_ERROR_INTERNAL = 12,
  MODRT_STATUS_MAX_ENUM = 0x7fffffff /* 32-bit enums; values other libraries may add stay valid */
} modrt_status;

/* "MODRT_OK", "MODRT_ERROR_FORMAT", ...; "MODRT_ERROR_UNKNOWN" for other values. */
MODRT_API const char* modrt_status_name(modrt_status status);
/* The message of the last failed call on this thread ("" when none failed yet). Valid until
 * the next failing call on this thread. Never null. */
MODRT_API const char* modrt_last_error(void);
/* MODRT_VERSION of the library; "0.3.0". */
MODRT_API uint32_t modrt_version(void);
MODRT_API const char* modrt_version_string(void);

/* The allocator hook. alloc returns memory aligned to `alignment` (a power of two <= 64) or
 * null (the call then fails with MODRT_ERROR_OUT_OF_MEMORY); free receives the pointer and the
 * size that alloc was asked for. Passing null for the allocator uses malloc/free; so does a
 * struct whose alloc or free is null.
 *
 * Extent (honest): the hook receives every allocation the runtime layer makes itself: the
 * handle objects, the file image read by *_load_file (freed before it returns), and a
 * context's own buffers (ld, albedo, the probe volume and vector irradiance it hands out) and
 * light list. The decoded operators of a dictionary or level and the backends' own state
 * (core / cpu / gles C++ objects with the lightmap and atlas, the direct-light evaluator, GL
 * objects) are allocated with the global operator new of the
 * process. docs/embedding.md lists the byte split for a sample level. */
typedef struct modrt_allocator {
  uint32_t struct_size; /* sizeof(modrt_allocator) */
  void* (*alloc)(size_t size, size_t alignment, void* user);
  void (*free)(void* ptr, size_t size, void* user);
  void* user;
} modrt_allocator;

/* ------------------------------------------------------------------------------------------
 * Dictionary and level. Both are parsed and fully validated at load (checksums, sizes, finite
 * values); `name` (may be null) starts every error message, e.g. the asset's name. The bytes
 * are not referenced after the call returns. */
typedef struct modrt_dictionary modrt_dictionary;
typedef struct modrt_level modrt_level;

MODRT_API modrt_status modrt_dictionary_load_memory(const void* data, size_t size, const char* name,
                                                    const modrt_allocator* allocator, modrt_dictionary** out);
MODRT_API modrt_status modrt_dictionary_load_file(const char* path, const modrt_allocator* allocator,
                                                  modrt_dictionary** out);
/* Releases the caller's reference (contexts keep their own). Null is ignored. */
MODRT_API void modrt_dictionary_destroy(modrt_dictionary* dictionary);

MODRT_API modrt_status modrt_level_load_memory(const void* data, size_t size, const char* name,
                                               const modrt_allocator* allocator, modrt_level** out);
MODRT_API modrt_status modrt_level_load_file(const char* path, const modrt_allocator* allocator,
                                             modrt_level** out);
MODRT_API void modrt_level_destroy(modrt_level* level);

typedef struct modrt_level_info {
  uint32_t struct_size; /* set by the caller: sizeof(modrt_level_info) */
  uint32_t block_count;
  uint32_t sample_count; /* lightmap samples; ld and lightmap hold 3 * sample_count floats */
  uint32_t res;          /* samples per face edge */
  uint32_t atlas_width, atlas_height;
  float bounds_min[3], bounds_max[3]; /* world box of every block corner */
} modrt_level_info;
MODRT_API modrt_status modrt_level_get_info(const modrt_level* level, modrt_level_info* out);

/* The albedo the level was built with (3 * sample_count floats, RGB in [0, 1], in ld order):
 * each face's authored albedo (modrt-level, from the level JSON). A context reflects its lights
 * with it unless modrt_context_set_albedo overrides it. */
MODRT_API modrt_status modrt_level_get_albedo(const modrt_level* level, float* out, size_t count);

/* One lightmap sample: where it is, which way it faces, whose it is. */
typedef struct modrt_level_sample {
  float position[3]; /* world position of the texel centre */
  float normal[3];   /* unit normal, pointing into its block (towards the light it receives) */
  uint32_t block;    /* owning block (modrt_level_get_block) */
  uint32_t face;     /* the block's canonical face (0..5: -X, +X, -Y, +Y, -Z, +Z) */
} modrt_level_sample;
/* Every sample in ld order (count = sample_count records): an app that computes ld itself
 * (a GPU pass, its own lights) writes ld[3 s + c] = albedo[3 s + c] * E_c(position_s) / pi.
 * Allocates scratch (operator new): call it at load time. */
MODRT_API modrt_status modrt_level_get_samples(const modrt_level* level, modrt_level_sample* out,
                                               size_t count);

/* One block of the level (architecture.md §4): a canonical dictionary shape, turned by quarter
 * turns about +Y and warped through its 8 corners. Per-face arrays are indexed by the
 * canonical face, whose world direction is world_face[f]. */
typedef struct modrt_level_block {
  uint32_t struct_size;   /* set by the caller: sizeof(modrt_level_block) */
  uint32_t shape;         /* dictionary shape index */
  uint32_t quarter_turns; /* canonical -> world: this many quarter turns about +Y (0..3) */
  uint32_t face_mask;     /* canonical faces present (walls): bit f for face f */
  int32_t cell[3];        /* grid cell */
  /* World corner x + 2y + 4z of the unit cube after the quarter turns: the canonical point p
   * of the block is at trilinear(corners, turn(p)), where turn applies (x, y, z) ->
   * (z, y, 1 - x) quarter_turns times (core's block_to_world). */
  float corners[8][3];
  uint32_t world_face[6];               /* world face (0..5) of each canonical face */
  int32_t neighbour[6];                 /* block joined through each canonical face, or -1 */
  float albedo[6][3];                   /* linear RGB per canonical face */
  uint32_t sample_offset, sample_count; /* the block's samples: [offset, offset + count) */
  int32_t tile_x[6], tile_y[6];         /* padded atlas tile origin per canonical face (-1: no wall) */
} modrt_level_block;
MODRT_API modrt_status modrt_level_get_block(const modrt_level* level, uint32_t index,
                                             modrt_level_block* out);

/* ------------------------------------------------------------------------------------------
 * Context: one level evaluated by one backend. */
typedef struct modrt_context modrt_context;

typedef enum modrt_backend {
  MODRT_BACKEND_CPU = 0,
  MODRT_BACKEND_GLES = 1,
  MODRT_BACKEND_MAX_ENUM = 0x7fffffff
} modrt_backend;

/* Returns the address of GL entry point `name`, or null (eglGetProcAddress, or dlsym on iOS). */
typedef void* (*modrt_gl_loader)(const char* name, void* user);

typedef struct modrt_context_options {
  uint32_t struct_size; /* sizeof(modrt_context_options): set by modrt_context_options_init */
  modrt_backend backend;
  int threads;         /* CPU: threads working on a frame, the caller's included (1 to 256) */
  int probes;          /* nonzero: update() also evaluates the volume probes (needs Ubvol) */
  int timing;          /* nonzero: per-stage timings (GLES: GPU timer queries where available) */
  int skip_unchanged;  /* nonzero: exact skipping of unchanged blocks, slots and tiles */
  uint32_t max_lights; /* modrt_context_set_lights accepts up to this many (1 to 4096) */
  int shadows;         /* nonzero: lights cast shadows against the level's walls */
  /* GLES only: loader for the caller's current context. Null: eglGetProcAddress (when the
   * library was built with EGL, else MODRT_ERROR_UNSUPPORTED). */
  modrt_gl_loader gl_loader;
  void* gl_loader_user;
  /* Since 0.3. Multi-bounce (architecture.md §2): every update runs the single-bounce
   * evaluation of ld and then `bounces` feedback steps, ld = ld_direct + rho min(max(lightmap,
   * 0), bound), each adding one bounce (0 to 64; 0: one bounce, as in 0.2). rho is the
   * context's albedo (the level's, or set_albedo's) clamped to max_albedo, which is in [0, 1):
   * the bound max(ld) / (1 - max rho) holds every bounce sum, so no lightmap value grows past
   * it (feedback_policy.h). With skip_unchanged, an update whose ld and albedo are those of the
   * last update runs nothing (frames_skipped). modrt_context_set_bounces changes it later.
   * MODRT_BOUNCES_CONVERGED: the converged multi-bounce every update instead; since 0.4 the
   * default (modrt_context_options_init, and null options). A caller whose struct_size is 0.2's
   * (it ends before this field) keeps 0.2's one bounce. */
  uint32_t bounces;
  float max_albedo;
  /* Since 0.3. Nonzero: every update also evaluates vector irradiance (MRT §6.4: four OHLSH
   * coefficients of E / pi per sample, in its face's frame, for normal-mapped surfaces). Needs
   * the dictionary's vector operators (modrt-bake bakes them by default); creation fails with
   * MODRT_ERROR_UNSUPPORTED without them. */
  int vector_irradiance;
} modrt_context_options;

/* Defaults: CPU, 1 thread, probes on, timing off, skipping on, 8 lights, shadows on, the
 * converged multi-bounce (MODRT_BOUNCES_CONVERGED; 0.3's default was 0: one bounce), max_albedo
 * 0.95, vector irradiance off. */
MODRT_API void modrt_context_options_init(modrt_context_options* options);

/* Checks that the level was built against the dictionary (MODRT_ERROR_MISMATCH otherwise),
 * then allocates every buffer. A GLES context is created on the GL context current on the
 * calling thread (OpenGL ES 3.0, or desktop GL 4.3+ with ES3 compatibility); the app owns that
 * context (EGL / EAGL) and its surface. options may be null (defaults). The context keeps a
 * reference to the level and the dictionary. */
MODRT_API modrt_status modrt_context_create(modrt_dictionary* dictionary, modrt_level* level,
                                            const modrt_context_options* options,
                                            const modrt_allocator* allocator, modrt_context** out);
/* GLES: the creating GL context must be current. Null is ignored. */
MODRT_API void modrt_context_destroy(modrt_context* context);

typedef struct modrt_sizes {
  uint32_t struct_size; /* set by the caller: sizeof(modrt_sizes) */
  size_t ld;            /* floats: 3 * samples (RGB interleaved) */
  size_t lightmap;      /* floats: 3 * samples */
  size_t atlas;         /* floats: 3 * atlas_width * atlas_height, row-major, row 0 first */
  size_t probes;        /* floats: 27 * probes per block * blocks (0 without probes) */
  uint32_t atlas_width, atlas_height;
  uint32_t probe_grid; /* g: g^3 probes per block (0 without probes) */
} modrt_sizes;
MODRT_API modrt_status modrt_context_get_sizes(const modrt_context* context, modrt_sizes* out);
/* "cpu avx2", "gles float32 targets, float32 operators", ... Never null for a valid context. */
MODRT_API const char* modrt_context_description(const modrt_context* context);

/* Per-sample albedo (3 * samples floats, RGB, finite, >= 0) that the lights are reflected
 * with: ld = albedo * E / pi. Optional: a context starts with the level's own albedo
 * (modrt_level_get_albedo); this overrides it (e.g. from the app's textures). Does not allocate;
 * the next set_lights recomputes every block. */
MODRT_API modrt_status modrt_context_set_albedo(modrt_context* context, const float* albedo, size_t count);
/* Copies the albedo the context reflects with (3 * samples floats). */
MODRT_API modrt_status modrt_context_read_albedo(const modrt_context* context, float* out, size_t count);

typedef enum modrt_light_type {
  MODRT_LIGHT_POINT = 0,
  MODRT_LIGHT_SPOT = 1,
  MODRT_LIGHT_DIRECTIONAL = 2,
  MODRT_LIGHT_MAX_ENUM = 0x7fffffff
} modrt_light_type;

/* modrt::cpu::CpuLight (cpu_neon/include/modrt/cpu/direct_light.h has the light models). */
typedef struct modrt_light {
  uint32_t struct_size; /* sizeof(modrt_light): set by modrt_light_init */
  modrt_light_type type;
  float position[3];              /* point, spot: world position */
  float direction[3];             /* spot: cone axis; directional: the direction the light travels */
  float color[3];                 /* linear RGB, >= 0 */
  float intensity;                /* point, spot: W/sr; directional: irradiance; >= 0 */
  float radius;                   /* point, spot: clamps 1/d^2 near the light; >= 0 */
  float inner_angle, outer_angle; /* spot: half-angles in radians, 0 <= inner <= outer <= pi */
  int shadows;                    /* nonzero: casts shadows (when the context has shadows on) */
} modrt_light;

/* Defaults: a white point light at the origin, intensity 1, radius 0, direction (0, -1, 0)
 * (down, y up), angles 0, shadows on. */
MODRT_API void modrt_light_init(modrt_light* light);

/* Evaluates ld from the lights on the CPU (only blocks a changed light reaches are redone)
 * for the next update. `lights` is an array of `count` modrt_light (each with its
 * struct_size). Fails naming the light index and field for a bad light. */
MODRT_API modrt_status modrt_context_set_lights(modrt_context* context, const modrt_light* lights,
                                                size_t count);
/* Sets ld directly (count = sizes.ld floats, finite, >= 0; the first bad sample is named). */
MODRT_API modrt_status modrt_context_set_ld(modrt_context* context, const float* ld, size_t count);
/* GLES: ld from a GL texture the app rendered itself (a GPU pass over the samples of
 * modrt_level_get_samples, with its own lights and shadows), read on the GPU by the following
 * updates: nothing is read back or uploaded. The texture is a GL_TEXTURE_2D of the context's GL
 * context in the layout modrt_context_get_ld_layout gives (sample s at texel (s % width,
 * s / width), ld in .rgb), a float format (RGBA32F, RGBA16F, RGB32F); its level 0 is read
 * through a nearest sampler, whatever its filters. It is not validated on the CPU: NaN and
 * negative values read as 0, values above 1e30 as 1e30. Every block is recomputed each update
 * (the runtime does not see the values to skip). It stays the source until set_ld or
 * set_lights. With options.bounces, the feedback bound's largest ld is found on the GPU too (two
 * reduction passes) and the fed-back light is clamped at 1e30 (set_ld refuses light whose
 * bounces could pass it), the clutter's feedback bound (a clutter albedo) included. Fails for a
 * CPU context, texture 0 or a name that is not a texture. */
MODRT_API modrt_status modrt_context_set_ld_texture(modrt_context* context, uint32_t texture);
/* The size of that texture: width = the layout's row length, height = rows. GLES only. */
MODRT_API modrt_status modrt_context_get_ld_layout(const modrt_context* context, uint32_t* width,
                                                   uint32_t* height);
/* A cube shadow map of a light, for modrt_context_set_light_gpu: a GL_TEXTURE_CUBE_MAP depth
 * texture of the context's GL context with GL_TEXTURE_COMPARE_MODE GL_COMPARE_REF_TO_TEXTURE,
 * face f a 90-degree perspective projection from the light position along the GL cube-map face
 * axes (+x, -x, +y, -y, +z, -z) with these near and far planes. A directional light's map is
 * orthographic, in the +x face alone (directional_view_proj). An 0.3 struct_size (up to
 * far_plane) is still accepted: no normal offset, and no directional shadows. */
typedef struct modrt_shadow_cube {
  uint32_t struct_size;        /* sizeof(modrt_shadow_cube): set by modrt_shadow_cube_init */
  uint32_t texture;            /* 0: no shadows */
  float near_plane, far_plane; /* 0 < near < far, finite */
  /* Since 0.4. How far (metres) the shadow test moves a sample along its normal, beyond the
   * shader's own offset against acne: 0 where the proxies lie on the surfaces they stand for;
   * where they lie inside walls (an imported level's proxies run through the walls'
   * mid-planes), how deep they lie, so that the wall's own faces do not shadow them. Finite,
   * >= 0. */
  float normal_offset;
  /* Since 0.4. A directional light's shadow map: this column-major matrix takes world
   * positions to the +x face's clip space (x, y in [-1, 1] across the face, z the depth from
   * near_plane to far_plane). Finite; unused for point and spot lights. */
  float directional_view_proj[16];
} modrt_shadow_cube;
/* Defaults: no texture, near 0.01, far 30, normal offset 0, the identity matrix. */
MODRT_API void modrt_shadow_cube_init(modrt_shadow_cube* shadow);

/* GLES (since 0.3): ld of one point, spot or (since 0.4) directional light evaluated at the
 * proxy samples on the GPU (one full-screen pass, gles::GlesDirectLight: the light model of
 * set_lights, with the context's albedo), shadowed by `shadow` when it is not null and names a
 * texture, and read by the following updates as a set_ld_texture texture of the context:
 * nothing is read back or uploaded. Without a shadow map nothing is shadowed (set_lights
 * shadows by the proxy walls). The light is checked as set_lights checks it (the error names
 * the field). On failure the previous ld source stays. CPU contexts: MODRT_ERROR_UNSUPPORTED
 * (use set_lights). */
MODRT_API modrt_status modrt_context_set_light_gpu(modrt_context* context, const modrt_light* light,
                                                   const modrt_shadow_cube* shadow);
/* Copies the ld the next update will use (sizes.ld floats): set_ld's, or set_lights' result.
 * Fails while the ld comes from a texture (set_ld_texture). */
MODRT_API modrt_status modrt_context_read_ld(const modrt_context* context, float* out, size_t count);

/* Evaluates the level for the current ld: b, r, lightmap (plus the feedback steps of
 * options.bounces or modrt_context_set_bounces), padded atlas (and probes when on). On failure the previous
 * results stay, except after a failed feedback step (a GL error), which leaves the results of the steps
 * before it. */
MODRT_API modrt_status modrt_context_update(modrt_context* context);

/* Since 0.4. The `bounces` value of the converged multi-bounce (docs/cpu.md "Converged
 * multi-bounce"): every update solves the bounce series to a relative tolerance of 1e-3 in the
 * reduced space (b, r, and with clutter its c), warm-started from the last update's solution,
 * then writes the lightmap, atlas, probes, vector irradiance and clutter lightmap once. CPU and
 * GLES contexts, with or without clutter (the clutter's light bounces with its albedo, as in
 * modrt_context_set_clutter_albedo); a GLES context solves on the GPU from b0 every update with
 * an a-priori iteration count (nothing read back, no warm start; docs/gles.md). A context
 * without a converged solve (none today) would run one evaluation and 4 feedback steps (core's
 * kConvergedFallbackSteps), every update alike, counted in modrt_solve_stats.fallback_updates. */
#define MODRT_BOUNCES_CONVERGED 0xffffffffu

/* Since 0.3. The multi-bounce feedback steps of the following updates (0 to 64, or
 * MODRT_BOUNCES_CONVERGED), as
 * options.bounces gives them at creation, changed without recreating the context (nothing is
 * allocated): e.g. more bounces while the light stands still, fewer while it moves. The next
 * update runs the single-bounce evaluation and then `bounces` feedback steps; with
 * skip_unchanged, an update is skipped only when its ld, albedo and bounce count are the last
 * update's. A value above 64 is MODRT_ERROR_INVALID_ARGUMENT naming `bounces`, and the count
 * stays as it was. modrt_context_get_bounces gives the current count. */
MODRT_API modrt_status modrt_context_set_bounces(modrt_context* context, uint32_t bounces);
MODRT_API modrt_status modrt_context_get_bounces(const modrt_context* context, uint32_t* bounces);

/* Since 0.4. Skip what the camera cannot see (docs/cpu.md "The camera skip"): the following
 * updates write the lightmap tiles and atlas rectangles of the potentially visible blocks only
 * (CPU: and the tiles of the neighbours their padding copies; GLES: the atlas pass and the
 * vector atlases over those rectangles); b and r stay every block's, since they carry light
 * to the visible ones. On a CPU context without clutter the probes are computed for the
 * visible blocks, and a hidden block's when modrt_context_probe_sh samples it or
 * modrt_context_read_probes reads them all, so every probe read is current (GLES: every
 * block's, its probe texture is sampled on the GPU). A block that comes into view gets this
 * frame's light in this call; the others' texels are not current.
 *   - modrt_context_set_camera: the blocks seen from `eye` (world position) through
 *     `view_projection` (16 floats, column-major, OpenGL clip space), by a conservative walk
 *     through the level's open faces; an eye outside every block sees every block.
 *   - modrt_context_set_visible_blocks: the app's own set, one flag per block (nonzero:
 *     visible; count = modrt_level_info.block_count); flags NULL with count 0: every block (off).
 * With n-space bounces (1..64) every feedback step reads the whole lightmap, so the skip saves
 * work only with bounces 0 or MODRT_BOUNCES_CONVERGED. Non-finite input and a wrong count are
 * MODRT_ERROR_INVALID_ARGUMENT / MODRT_ERROR_NON_FINITE naming the argument, and nothing
 * changes. Allocates nothing. */
MODRT_API modrt_status modrt_context_set_camera(modrt_context* context, const float view_projection[16],
                                                const float eye[3]);
MODRT_API modrt_status modrt_context_set_visible_blocks(modrt_context* context, const uint8_t* flags,
                                                        size_t count);

/* GLES: the GL texture name of the padded lightmap atlas (GL_TEXTURE_2D, RGB in .rgb;
 * *format receives 0 for RGBA32F, 1 for RGBA16F, 2 for RGBA32UI holding float bits, which
 * must be fetched with texelFetch). CPU contexts: MODRT_ERROR_UNSUPPORTED. format may be null. */
MODRT_API modrt_status modrt_context_get_atlas_texture(const modrt_context* context, uint32_t* texture,
                                                       int* format);
/* CPU: the context's own atlas after the last update (sizes.atlas floats), valid until the
 * next update or destroy; no copy. GLES: MODRT_ERROR_UNSUPPORTED (use read_atlas). */
MODRT_API modrt_status modrt_context_get_atlas_data(const modrt_context* context, const float** data,
                                                    size_t* count);
/* Copies of the last update's lightmap (sizes.lightmap floats) and atlas (sizes.atlas floats).
 * GLES: reads back from the GPU (waits for it). */
MODRT_API modrt_status modrt_context_read_lightmap(modrt_context* context, float* out, size_t count);
MODRT_API modrt_status modrt_context_read_atlas(modrt_context* context, float* out, size_t count);

/* Vector irradiance of the last update (options.vector_irradiance). Per sample s, coefficient
 * i (0..3) and channel c: out[3 (4 s + i) + c], count = 4 * sizes.lightmap floats. Coefficient
 * i is in the frame of the sample's face: modrt_mapped_corner.face_u / face_v and the normal
 * (core's sh.h, ohlsh_eval): a normal map's perturbed normal n in that frame gives
 * E(n) / pi = sum_i coefficient_i * ohlsh_i(n). GLES: reads back from the GPU (waits). */
MODRT_API modrt_status modrt_context_read_vector_lightmap(modrt_context* context, float* out, size_t count);
/* Coefficient `coefficient` (0..3) laid out as the padded atlas (sizes.atlas floats, padding
 * filled), ready to upload next to the atlas. GLES: reads back (use the textures instead). */
MODRT_API modrt_status modrt_context_read_vector_atlas(modrt_context* context, int coefficient, float* out,
                                                       size_t count);
/* GLES: the four coefficient atlases as GL textures (the atlas's layout and *format, RGB in
 * .rgb), textures[i] for coefficient i. CPU contexts: MODRT_ERROR_UNSUPPORTED. */
MODRT_API modrt_status modrt_context_get_vector_textures(const modrt_context* context, uint32_t textures[4],
                                                         int* format);

typedef enum modrt_probe_kind {
  MODRT_PROBE_RADIANCE = 0,           /* SH9 of incident radiance */
  MODRT_PROBE_IRRADIANCE_OVER_PI = 1, /* SH9 of E / pi: shade a diffuse surface by its normal */
  MODRT_PROBE_MAX_ENUM = 0x7fffffff
} modrt_probe_kind;
/* SH9 at world position `position` from the last update's probe volume (needs probes on):
 * trilinear between the g^3 probes of the block containing the point, rotated into the world
 * frame. out[3 * k + c]: coefficient k (sh.h order: 1, y, z, x, xy, yz, 3z^2 - 1, xz,
 * x^2 - y^2), channel c. A point outside every block by more than 1% of a block is an error.
 * GLES: the first query after an update reads the probes back from the GPU. */
MODRT_API modrt_status modrt_context_probe_sh(modrt_context* context, const float position[3],
                                              modrt_probe_kind kind, float out[27]);

/* Since 0.3. Where a world point lies in the probe volume, for a shader that samples the volume
 * itself (modrt_context_get_probe_texture, or read_probes uploaded): the cell of 2 x 2 x 2 probes
 * that modrt_context_probe_sh interpolates (core's ProbeSampler::locate). The probes of
 * read_probes and the probe texture are already in the world frame, so
 *   sh = sum over c < 8 of corner_weight[c] * probe p = probe[c]   (read_probes' probe order;
 *        texel 9 p + k of the probe texture for coefficient k)
 * is modrt_context_probe_sh's value at `position` (MODRT_PROBE_RADIANCE; scale bands as there
 * for E/pi). Independent of the light: call it once for a static object, or per frame for a
 * moving one on the CPU, and pass the 8 indices and weights to the shader. Needs probes on
 * (MODRT_ERROR_UNSUPPORTED otherwise), not an update. */
typedef struct modrt_probe_cell {
  uint32_t struct_size;   /* set by the caller: sizeof(modrt_probe_cell) */
  uint32_t block;         /* the block containing the point (modrt_level_get_block) */
  uint32_t quarter_turns; /* that block's canonical -> world turn (0..3; modrt_level_block's) */
  uint32_t grid;          /* g: probes per block axis (modrt_sizes.probe_grid) */
  /* The lower corner (i, j, k) of the cell on the block's canonical g^3 grid (0 .. g - 2, or 0
   * when g is 1) and the trilinear weights towards i + 1, j + 1, k + 1 in [0, 1] (the value is
   * held beyond the outermost probe centres: a weight is then 0 or 1). */
  int32_t lower[3];
  float weight[3];
  /* The 8 probes of the cell, corner c = x + 2y + 4z (x, y, z in {0, 1}: lower + (x, y, z),
   * clamped to g - 1), as global probe indices p = block g^3 + i + g (j + g k), with their
   * weights (products of weight[] and 1 - weight[]; they sum to 1). */
  uint32_t probe[8];
  float corner_weight[8];
} modrt_probe_cell;
/* Fails naming the argument: a null context, position or out, out.struct_size, a position that
 * is not finite (MODRT_ERROR_NON_FINITE) or lies outside every block by more than 1% of a
 * block (MODRT_ERROR_INVALID_ARGUMENT); *out is then unchanged. Does not allocate. */
MODRT_API modrt_status modrt_context_locate_probe(const modrt_context* context, const float position[3],
                                                  modrt_probe_cell* out);

/* The whole probe volume of the last update in the world frame (sizes.probes floats), for
 * sampling on the GPU: probe p = i + g (j + g k) of block b (g = sizes.probe_grid; (i, j, k) on
 * the block's canonical grid) at out[27 (b g^3 + p) + 3 k + c], coefficient k, channel c, as
 * modrt_context_probe_sh gives it at that probe's position (modrt_context_get_probe_positions).
 * Upload it as a buffer or a 3D texture per block. GLES: reads back from the GPU once per update. */
MODRT_API modrt_status modrt_context_read_probes(modrt_context* context, modrt_probe_kind kind, float* out,
                                                 size_t count);
/* GLES (since 0.3): the probe volume of the last update as a GL texture, for sampling on the GPU
 * (no readback): texel i = 9 p + k of probe p (read_probes' order) at (i % width, i / width),
 * radiance SH9 coefficient k in the world frame in .rgb (MODRT_PROBE_RADIANCE; scale bands 1 and
 * 2 by 2/3 and 1/4 for E/pi), *format as the atlas's. One GPU pass on the first call after an
 * update. CPU contexts: MODRT_ERROR_UNSUPPORTED (use read_probes). format, width, height may be
 * null. */
MODRT_API modrt_status modrt_context_get_probe_texture(modrt_context* context, uint32_t* texture, int* format,
                                                       uint32_t* width, uint32_t* height);
/* World position of every probe (3 * blocks * g^3 floats, the order of read_probes). */
MODRT_API modrt_status modrt_context_get_probe_positions(const modrt_context* context, float* out,
                                                         size_t count);

/* Wall-clock / GPU nanoseconds of the stages of the last set_lights and update (timing on;
 * otherwise only light_ns and update_ns), summed over the update's bounces. CPU: r runs in the lightmap's
 * task per block, so r_ns is 0 and lightmap_ns covers r and the tiles. GLES: the lightmap is written
 * straight into the atlas, so lightmap_ns is 0 and atlas_ns covers it. */
typedef struct modrt_timings {
  uint32_t struct_size; /* set by the caller: sizeof(modrt_timings) */
  uint64_t light_ns;    /* set_lights: the CPU direct-light evaluation */
  uint64_t upload_ns;   /* GLES: ld upload */
  uint64_t b_ns, r_ns, lightmap_ns, atlas_ns, probes_ns;
  uint64_t update_ns;   /* the whole modrt_context_update call, CPU clock */
  uint64_t feedback_ns; /* since 0.3: the multi-bounce feedback (ld from the lightmap) */
} modrt_timings;
MODRT_API modrt_status modrt_context_get_timings(const modrt_context* context, modrt_timings* out);

/* Work skipped, summed over every update since creation. A block's b is kept when its ld did
 * not change, a slot's r when none of its sources' b changed, a tile when its b and incoming r
 * did not change (exact: results are bit-identical to recomputing). light_blocks_*: blocks
 * whose ld set_lights recomputed or kept (only blocks a changed light reaches are redone). */
typedef struct modrt_skip_stats {
  uint32_t struct_size;     /* set by the caller: sizeof(modrt_skip_stats) */
  uint64_t frames;          /* successful updates */
  uint64_t frames_skipped;  /* nothing was recomputed: ld identical to the last update (with
                               bounces: ld and albedo identical) */
  uint64_t blocks_computed; /* b evaluated */
  uint64_t blocks_kept;
  uint64_t slots_computed; /* slots whose r was evaluated */
  uint64_t slots_kept;     /* slots whose r was reused */
  uint64_t tiles_written;  /* blocks whose lightmap tiles were rewritten */
  uint64_t tiles_kept;     /* blocks whose tiles were left as they were */
  uint64_t light_blocks_recomputed;
  uint64_t light_blocks_kept;
  /* Since 0.4 (an 0.3 struct_size, up to light_blocks_kept, is still accepted): the camera
   * skip (modrt_context_set_camera). tiles_hidden: changed tiles of blocks the camera could not
   * see, left unwritten (tiles_written + tiles_kept + tiles_hidden = evaluations x blocks);
   * tiles_caught_up: such tiles written later, when their block came into view or a feedback
   * step needed the whole lightmap. */
  uint64_t tiles_hidden;
  uint64_t tiles_caught_up;
} modrt_skip_stats;
MODRT_API modrt_status modrt_context_get_skip_stats(const modrt_context* context, modrt_skip_stats* out);

/* Since 0.4. The converged multi-bounce (MODRT_BOUNCES_CONVERGED), summed since creation and for
 * the last converged update. The solve stops when its estimated remaining error (error_bound)
 * is at most 1e-3 of max |b|; converged is 0 when it ran out of iterations instead (256; the
 * update still succeeds with that b). spectral_radius: of the reduced feedback operator M,
 * estimated at the first converged update after the albedo is set (below 1 for a physical
 * albedo; above 0.98 M is damped by damping = 0.98 / spectral_radius); contraction: the rate
 * of the iteration in use. All zero before the first converged update. A GLES context runs
 * ceil(log 1e-3 / log contraction) iterations (at most 256) and does not read its residual
 * back: last_residual and last_error_bound are then that count's a-priori bound
 * contraction^iterations, and converged says it is within 1e-3. */
typedef struct modrt_solve_stats {
  uint32_t struct_size; /* set by the caller: sizeof(modrt_solve_stats) */
  uint32_t converged;   /* the last solve met the tolerance (1) or ran out of iterations (0) */
  uint64_t solves;      /* converged updates */
  uint64_t iterations;  /* applications of M, over every solve */
  uint32_t last_iterations;
  float last_residual;    /* max |b0 + M b - b| / max |b| at the last iterate */
  float last_error_bound; /* the estimated relative error of the last b */
  float damping;
  double spectral_radius;
  double contraction;
  uint64_t build_ns; /* the last build of the reduced operators (at the first solve after set_albedo) */
  uint64_t fallback_updates; /* MODRT_BOUNCES_CONVERGED updates run as one evaluation and 4
                                feedback steps: the context had no converged solve (0 with
                                today's backends) */
  /* Blocks the solves applied M to, over every solve. A CPU context without clutter
   * solves incrementally: each pass applies M only to the blocks whose b still changes by more
   * than the tolerance allows, so blocks_applied / (iterations x blocks) is below 1 and an
   * update whose light did not change runs 0 iterations; elsewhere it is iterations x blocks. */
  uint64_t blocks_applied;
} modrt_solve_stats;
MODRT_API modrt_status modrt_context_get_solve_stats(const modrt_context* context, modrt_solve_stats* out);

/* ------------------------------------------------------------------------------------------
 * Lightmap coordinates for the app's own static meshes (MRT §7.2's proxy mapping; core's
 * modrt/mesh_lightmap_uv.h has the details). Every triangle of a mesh given in world space is
 * assigned to one present face of the level block containing it and projected onto that face
 * through the block's warp, which gives atlas texel coordinates inside that face's tile: draw
 * the mesh sampling the padded atlas (modrt_context_get_atlas_texture / _data) there.
 * Triangles that cross the shared face of two blocks are cut along it (exactly for unwarped
 * blocks and flat faces; a triangle crossing a twisted warped face stays whole and goes to the
 * block containing its centroid), so that no output triangle straddles two tiles. The output
 * is a non-indexed triangle list: three modrt_mapped_corner per output triangle.
 *
 * Call sequence (at load time; both calls allocate scratch with operator new):
 *   modrt_mesh_input mesh;  modrt_mesh_input_init(&mesh);  ...set the pointers and counts...
 *   size_t corners;  modrt_level_map_mesh_bound(level, &mesh, &corners);
 *   allocate corners * sizeof(modrt_mapped_corner);
 *   modrt_level_map_mesh(level, &mesh, out, corners, &written, NULL);   // written == corners
 * How many pieces a triangle makes depends on how many blocks it spans, so the bound is
 * computed from the level and the mesh (the same cutting, without writing): it is exact. */
typedef struct modrt_mesh_input {
  uint32_t struct_size; /* sizeof(modrt_mesh_input): set by modrt_mesh_input_init */
  /* World x, y, z (3 floats) of vertex i at (const char*)positions + i * position_stride;
   * likewise the normals (finite, not zero; they need not be unit). A stride of 0 means 3
   * floats (tight); otherwise at least 12. Interleaved vertex buffers work as they are. */
  const float* positions;
  size_t position_stride;
  const float* normals;
  size_t normal_stride;
  size_t vertex_count;
  const uint32_t* indices; /* three per triangle, each < vertex_count */
  size_t index_count;      /* a multiple of 3 */
} modrt_mesh_input;

/* Zeroes `mesh` and sets struct_size (tight strides). Null is ignored. */
MODRT_API void modrt_mesh_input_init(modrt_mesh_input* mesh);

/* One corner of an output triangle. */
typedef struct modrt_mapped_corner {
  float position[3]; /* world: an input vertex's own, or a point on a cut */
  float normal[3];   /* the input normal, interpolated and normalised on cuts */
  /* Atlas texel coordinates (continuous; x + 0.5 is a texel centre) in the padded atlas:
   * divide by atlas_width / atlas_height for [0, 1] texture coordinates. */
  float lightmap[2];
  /* The face's OHLSH frame in world space (vector irradiance is in this frame). */
  float face_u[3], face_v[3];
  /* Weights of the source triangle's corners 0, 1, 2 at this corner: interpolate the app's
   * own attributes (UVs, tangents, colours) with them. An input vertex has one weight 1. */
  float barycentric[3];
  uint32_t triangle; /* source triangle: indices[3 * triangle + k] */
  uint32_t block;    /* level block whose tile is sampled */
  uint32_t face;     /* its canonical face (0..5: -X, +X, -Y, +Y, -Z, +Z) */
  uint32_t outside;  /* nonzero: the piece lies in no block and was mapped to the nearest one */
} modrt_mapped_corner;

typedef struct modrt_mesh_map_stats {
  uint32_t struct_size;     /* set by the caller: sizeof(modrt_mesh_map_stats) */
  size_t triangles;         /* input triangles */
  size_t split_triangles;   /* cut into pieces in more than one block */
  size_t triangles_outside; /* with a part in no block (mapped to the nearest block) */
  size_t corners;           /* output corners, 3 per output triangle */
} modrt_mesh_map_stats;

/* The exact number of corners modrt_level_map_mesh writes for `mesh`. Fails as it does. */
MODRT_API modrt_status modrt_level_map_mesh_bound(const modrt_level* level, const modrt_mesh_input* mesh,
                                                  size_t* corners);
/* Maps `mesh` onto `level` into out[0 .. *written). capacity: corners `out` holds; fewer
 * than the bound is MODRT_ERROR_INVALID_ARGUMENT with nothing written. Bad input is named:
 * a non-finite position (MODRT_ERROR_NON_FINITE, "positions[i]"), an index out of range
 * ("indices[i]"), a zero normal, a stride below 12 bytes, a null pointer. stats may be null. */
MODRT_API modrt_status modrt_level_map_mesh(const modrt_level* level, const modrt_mesh_input* mesh,
                                            modrt_mapped_corner* out, size_t capacity, size_t* written,
                                            modrt_mesh_map_stats* stats);

/* ------------------------------------------------------------------------------------------
 * DRT clutter (since 0.3; architecture.md §6, docs/drt.md): objects inside the level's blocks
 * (furniture, props) that cast indirect shadows on the walls, reflect light onto them and onto
 * each other, and get a lightmap of their own. Their operators are built offline for one level
 * (modrt-demo --save-clutter writes a .modrtdrt file) and set on a context of that level. A
 * clutter's texels are numbered over all its objects, object by object. */
typedef struct modrt_clutter modrt_clutter;

/* Parsed and validated (checksums, sizes, finite values) at load; `name` (may be null) starts
 * every error message. An older file is MODRT_ERROR_VERSION_MISMATCH ("rebuild the clutter
 * operators"). */
MODRT_API modrt_status modrt_clutter_load_memory(const void* data, size_t size, const char* name,
                                                 const modrt_allocator* allocator, modrt_clutter** out);
MODRT_API modrt_status modrt_clutter_load_file(const char* path, const modrt_allocator* allocator,
                                               modrt_clutter** out);
/* Releases the caller's reference (contexts keep their own). Null is ignored. */
MODRT_API void modrt_clutter_destroy(modrt_clutter* clutter);

typedef struct modrt_clutter_info {
  uint32_t struct_size; /* set by the caller: sizeof(modrt_clutter_info) */
  uint32_t object_count;
  uint32_t texel_count;        /* clutter light, albedo and lightmap hold 3 * texel_count floats */
  uint32_t has_texel_geometry; /* 1: modrt_clutter_get_texels gives positions and normals */
} modrt_clutter_info;
MODRT_API modrt_status modrt_clutter_get_info(const modrt_clutter* clutter, modrt_clutter_info* out);

/* One clutter texel: where it is and which way it faces, for the app's own direct light. */
typedef struct modrt_clutter_texel {
  float position[3]; /* world position of the texel centre */
  float normal[3];   /* unit outward normal */
  uint32_t object;   /* the object it belongs to */
} modrt_clutter_texel;
/* Every texel (count = texel_count records). MODRT_ERROR_UNSUPPORTED when the file does not
 * record them (has_texel_geometry 0). */
MODRT_API modrt_status modrt_clutter_get_texels(const modrt_clutter* clutter, modrt_clutter_texel* out,
                                                size_t count);

/* Since 0.3 (.modrtdrt version 3). The lightmap cell a clutter texel stands for, so that an app
 * builds its clutter mesh's lightmap UVs (or a cell -> texel map) itself: texel t is cell
 * (u, v) (column, row) of the res x res grid on face `face` of object `object`.
 *   - A mesh object (DRT §3): `face` is the chart; the grid is the mesh's lightmap atlas at the
 *     res the operators were built with (its UV set, [0, 1]^2): the texel covers UV
 *     [u, u + 1] / res x [v, v + 1] / res. Cells no UV triangle covers have no texel (pad them
 *     from a neighbour).
 *   - A box object: `face` is its lit face (0..5: -X, +X, -Y, +Y, -Z, +Z in the box's local
 *     frame), the texel centre at (u + 0.5, v + 0.5) / res along the face's u and v axes.
 * No two texels of an object share (face, u, v). With a GLES context,
 * modrt_context_get_clutter_texel_coords gives where each texel lies in the clutter atlas
 * texture: together they map a mesh's lightmap cell to the atlas texel to sample. */
typedef struct modrt_clutter_cell {
  uint32_t object; /* the object it belongs to */
  uint32_t face;   /* mesh: chart; box: face 0..5 */
  uint32_t u, v;   /* column and row, < res */
  uint32_t res;    /* the object's grid edge */
} modrt_clutter_cell;
/* Every texel's cell (count = texel_count records). MODRT_ERROR_UNSUPPORTED when the operators
 * do not record them (operators assembled without cells); a wrong count or a null pointer is
 * MODRT_ERROR_INVALID_ARGUMENT naming it, with nothing written. */
MODRT_API modrt_status modrt_clutter_get_texel_cells(const modrt_clutter* clutter, modrt_clutter_cell* out,
                                                     size_t count);

/* The clutter the context's updates include, checked against the context's level
 * (MODRT_ERROR_MISMATCH names the object and the operator); null removes it. The context keeps
 * a reference. Its light starts at 0 and it has no albedo (no clutter feedback) until set. */
MODRT_API modrt_status modrt_context_set_clutter(modrt_context* context, modrt_clutter* clutter);
/* The clutter's light for the following updates, 3 * texel_count floats each, finite and
 * >= 0: clutter_ld = albedo * E / pi at each texel (what DRT's Td_c reads, as ld is for the
 * walls); clutter_direct (may be null: none) is added to the clutter lightmap, so that it holds
 * the clutter's total light. A failed call changes nothing. */
MODRT_API modrt_status modrt_context_set_clutter_light(modrt_context* context, const float* clutter_ld,
                                                       const float* clutter_direct, size_t count);
/* The clutter's albedo for multi-bounce (options.bounces > 0): each feedback step then also
 * feeds the clutter's indirect light back, clamped like the walls' (options.max_albedo).
 * 3 * texel_count floats in [0, 1e30]; null with count 0: no clutter feedback. */
MODRT_API modrt_status modrt_context_set_clutter_albedo(modrt_context* context, const float* albedo,
                                                        size_t count);
/* The clutter lightmap of the last update (3 * texel_count floats: the indirect light at each
 * texel, as E/pi, plus clutter_direct). GLES: reads back from the GPU. */
MODRT_API modrt_status modrt_context_read_clutter_lightmap(modrt_context* context, float* out, size_t count);
/* GLES: the clutter atlas of the last update as a GL texture (the atlas's *format; RGB in .rgb)
 * and its size; texel t of the clutter lies at (xy[2 t], xy[2 t + 1]) of
 * modrt_context_get_clutter_texel_coords (xy: 2 * texel_count values). CPU contexts:
 * MODRT_ERROR_UNSUPPORTED (use read_clutter_lightmap). */
MODRT_API modrt_status modrt_context_get_clutter_texture(const modrt_context* context, uint32_t* texture,
                                                         int* format, uint32_t* width, uint32_t* height);
MODRT_API modrt_status modrt_context_get_clutter_texel_coords(const modrt_context* context, uint32_t* xy,
                                                              size_t count);

#ifdef __cplusplus
} /* extern "C" */
#endif

#endif /* MODRT_MODRT_H */
