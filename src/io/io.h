/* io.h: the public header of obscura's I/O module (prefix io_).
 *
 * glTF 2.0 scenes (through tinygltf, with our own range checks), EXR and PNG images (through
 * OpenImageIO), a small JSON writer for sidecars, and atomic file output.
 *
 * The implementation of the glTF and image parts is C++17 behind this C header
 * (io_gltf.cpp, oiio/io_image_oiio.cpp); everything else is C11. OpenImageIO is linked only into
 * the image module (obscura_image_oiio.so), which obscura_io loads the first time an image is
 * read or written, never into the core or at process start (docs/io.md, "The image module"). If
 * the module cannot be loaded, the image functions return IO_ERROR with a message naming it;
 * OBSCURA_IMAGE_MODULE=PATH chooses the module file.
 *
 * Every function that writes a file writes "<path>.tmp.<pid>.<n>" first and renames it onto
 * <path> only when complete, so a reader never sees a partial file; on failure the temporary
 * file is removed.
 */
#ifndef IO_H
#define IO_H

#include "../core/obs.h"

#include <stdio.h>

#ifdef __cplusplus
extern "C" {
#endif

/* ------------------------------------------------------------------------------------------------
 * Atomic output
 * ---------------------------------------------------------------------------------------------- */

/* Write len bytes to path atomically (temp file, fsync, rename).
 * Returns: OK; INVALID_ARGUMENT; IO_ERROR (message names the path and errno text). */
obs_status io_write_file_atomic(obs_context *ctx, const char *path, const void *data, size_t len);

/* mkdir -p dir (every missing directory of the path). Returns OK, INVALID_ARGUMENT (too long),
 * IO_ERROR (the message names the directory and errno text). */
obs_status io_make_dirs(obs_context *ctx, const char *dir);

/* For writers that stream (or hand a path to a library): make a unique temporary path beside
 * `path` (same directory, so rename is atomic). tmp must hold at least strlen(path)+48 bytes. */
obs_status io_temp_path(obs_context *ctx, const char *path, char *tmp, size_t tmp_size);
/* rename(tmp, path); on failure remove tmp. */
obs_status io_commit_temp(obs_context *ctx, const char *tmp, const char *path);
/* Read a whole file into a malloc'd buffer (NUL-terminated for convenience; *len excludes it).
 * max_bytes guards against absurd inputs. Returns OK, IO_ERROR, LIMIT_EXCEEDED, OUT_OF_MEMORY. */
obs_status io_read_file(obs_context *ctx, const char *path, size_t max_bytes, char **data, size_t *len);

/* ------------------------------------------------------------------------------------------------
 * JSON writer (for sidecars, reports): builds compact-but-readable JSON in memory.
 * ---------------------------------------------------------------------------------------------- */

typedef struct io_json {
    char *buf;
    size_t len, cap;
    int depth;
    int need_comma[64];
    int failed;          /* set on allocation failure or nesting > 64; output then unusable */
} io_json;

void io_json_init(io_json *j);
void io_json_free(io_json *j);
void io_json_begin_object(io_json *j, const char *key);   /* key NULL inside arrays / at top */
void io_json_end_object(io_json *j);
void io_json_begin_array(io_json *j, const char *key);
void io_json_end_array(io_json *j);
/* Escapes per RFC 8259; keys and values that are not well-formed UTF-8 get U+FFFD for each
 * offending byte (JSON text must be UTF-8). */
void io_json_string(io_json *j, const char *key, const char *value);
void io_json_number(io_json *j, const char *key, double value);       /* %.9g; non-finite -> null */
void io_json_int(io_json *j, const char *key, int64_t value);
void io_json_bool(io_json *j, const char *key, int value);
void io_json_null(io_json *j, const char *key);
void io_json_floats(io_json *j, const char *key, const float *v, int n);  /* an array of numbers */
/* Insert an already-serialised JSON value (object, array, ...) verbatim. The caller vouches for
 * its validity (used for glTF extras kept from a loaded file, and for nested documents). */
void io_json_raw(io_json *j, const char *key, const char *raw);
/* 1 when the NUL-terminated s is well-formed UTF-8 (RFC 3629: no overlong forms, no surrogates,
 * nothing above U+10FFFF), the only text io_json writes unchanged (other bytes become U+FFFD). */
int io_json_utf8_valid(const char *s);
/* Write the document atomically to path (adds a trailing newline). Returns INVALID_ARGUMENT for
 * a document that failed, is empty or is still open; IO_ERROR when the file cannot be written. */
obs_status io_json_write(obs_context *ctx, const io_json *j, const char *path);

/* ------------------------------------------------------------------------------------------------
 * glTF 2.0
 * ---------------------------------------------------------------------------------------------- */

typedef struct io_gltf_options {
    int scene_index;        /* -1 = the file's default scene (or scene 0) */
    int require_triangles;  /* 1 (default): a primitive in any other mode is an UNSUPPORTED error;
                               0: such primitives are skipped with a warning */
} io_gltf_options;

io_gltf_options io_gltf_options_default(void);

/* Load a .gltf (external or data-URI buffers) or .glb file into out (which is initialised
 * first, and left empty on failure). Every accessor, bufferView and buffer range is checked
 * before it is read; counts are checked against ctx's limits; the node graph is checked for
 * cycles; obs_scene_validate runs at the end.
 * Returns: OK; IO_ERROR (missing or unreadable file or buffer); PARSE_ERROR (malformed or
 * inconsistent content: the message names the file and the offending object, e.g.
 * "accessor 3 (bufferView 1): byteOffset 64 + stride 12 * (count 1000 - 1) + 12 > byteLength 96");
 * UNSUPPORTED (non-triangle modes, sparse accessors, unknown required extensions);
 * NOT_FOUND (opt->scene_index names no scene); LIMIT_EXCEEDED; OUT_OF_MEMORY. */
obs_status io_gltf_load(obs_context *ctx, const char *path, const io_gltf_options *opt, obs_scene *out);

/* The same loader over len bytes in memory (a .gltf's JSON text or a .glb). `name` stands for the
 * path in messages and in out->source ("<memory>" when NULL); a name ending in ".glb", or bytes
 * starting with the "glTF" magic, select the binary container. Buffers must be inside the bytes
 * (the GLB BIN chunk or data: URIs): an external URI resolves against nothing and gives IO_ERROR.
 * Same checks and statuses as io_gltf_load (for fuzzing and for callers that hold the bytes). */
obs_status io_gltf_load_memory(obs_context *ctx, const char *name, const void *data, size_t len,
                               const io_gltf_options *opt, obs_scene *out);

/* Write a scene as a .glb (binary glTF 2.0) atomically: meshes (POSITION, NORMAL, indices as
 * UNSIGNED_INT), one node per instance with its matrix, cameras as nodes, lights through
 * KHR_lights_punctual, materials with extras. Used by the data generator and round-trip tests. */
obs_status io_glb_write(obs_context *ctx, const char *path, const obs_scene *scene);

/* ------------------------------------------------------------------------------------------------
 * Images
 * ---------------------------------------------------------------------------------------------- */

typedef enum io_pixel_type {
    IO_PIXEL_FLOAT = 0,   /* 32-bit float channel */
    IO_PIXEL_HALF,        /* stored as half in EXR (written from float) */
    IO_PIXEL_UINT,        /* 32-bit unsigned int channel */
    IO_PIXEL_COUNT
} io_pixel_type;

/* One named channel: a plane view. Exactly one of f32 / u32 is set, matching type
 * (HALF uses f32). Names follow EXR/Blender conventions: "Z", "N.X", "Ng.X", "primid", ... */
typedef struct io_channel {
    const char *name;
    io_pixel_type type;
    const obs_image_f32 *f32;
    const obs_image_u32 *u32;
} io_channel;

typedef enum io_attr_type {
    IO_ATTR_STRING = 0,
    IO_ATTR_FLOAT,
    IO_ATTR_INT,
    IO_ATTR_MATRIX44,     /* 16 floats, stored as EXR m44f (row-major in the file, see conventions) */
    IO_ATTR_FLOATS,       /* a float array of n elements */
    IO_ATTR_COUNT
} io_attr_type;

/* One metadata attribute. Names are namespaced "obscura:..." except standard EXR ones
 * ("worldToCamera", "worldToNDC" ...). */
typedef struct io_attr {
    char name[96];
    io_attr_type type;
    char *s;          /* STRING (owned by the holder) */
    float f;          /* FLOAT */
    int64_t i;        /* INT */
    float *v;         /* MATRIX44 (16) and FLOATS (n), owned by the holder */
    int n;
} io_attr;

/* Write a multi-channel EXR (ZIP compression, scanline) atomically. All channels must have the
 * same size. The file carries no time stamp unless the caller passes "DateTime", so identical
 * inputs give identical bytes. Returns: OK; INVALID_ARGUMENT (size mismatch, duplicate channel
 * names, INT attributes outside 32 bits); LIMIT_EXCEEDED (size overflow); OUT_OF_MEMORY; IO_ERROR. */
obs_status io_exr_write(obs_context *ctx, const char *path, const io_channel *channels, int channel_count,
                        const io_attr *attrs, int attr_count);

/* An image read from a file: planes by name, all as float32 except UINT channels. Owned. */
typedef struct io_image {
    int width, height;
    int channel_count;
    char (*names)[64];          /* channel_count names */
    io_pixel_type *types;       /* FLOAT for float and half, UINT for uint */
    obs_image_f32 *f32;         /* channel_count planes (data NULL for uint channels) */
    obs_image_u32 *u32;         /* channel_count planes (data NULL for float channels) */
    io_attr *attrs;             /* every attribute OIIO reports, converted; owned */
    int attr_count;
} io_image;

/* Read any image OpenImageIO can read (EXR in particular): the first subimage's data window
 * (width x height = the data window's; pixel (0, 0) = its first pixel; the data window's origin
 * and the display window are not reported; docs/ao/README.md, "External G-buffers").
 * Values come back exactly as stored (alpha is not multiplied in). Checks the size against ctx's
 * max_image_pixels and max_memory_bytes before allocating. Returns OK, IO_ERROR (missing or
 * unreadable), PARSE_ERROR (anything OpenImageIO cannot decode), UNSUPPORTED (deep or volume
 * images), LIMIT_EXCEEDED, OUT_OF_MEMORY; on failure *out is empty. */
obs_status io_image_read(obs_context *ctx, const char *path, io_image *out);
/* The same reader over len bytes in memory (through OpenImageIO's IOMemReader). `name` stands for
 * the path in messages ("<memory>" when NULL or empty). EXR and PNG bytes are recognised by their
 * magic numbers; other formats by the name's extension, as a file name would be. Same statuses
 * as io_image_read (no bytes: PARSE_ERROR). */
obs_status io_image_read_memory(obs_context *ctx, const char *name, const void *data, size_t len, io_image *out);
void io_image_free(io_image *im);
/* Index of a channel by exact name, or -1. */
int io_image_find_channel(const io_image *im, const char *name);
const io_attr *io_image_find_attr(const io_image *im, const char *name);

typedef enum io_png_encoding {
    IO_PNG_SRGB = 0,   /* values are linear; encoded with the sRGB transfer function (IEC 61966-2-1) */
    IO_PNG_LINEAR,     /* values are written as-is (quantised linearly); tagged linear */
    IO_PNG_COUNT
} io_png_encoding;

/* Write an 8-bit PNG atomically from 1 (grey), 3 (RGB) or 4 (RGBA) float planes in [0,1]
 * (clamped; NaN -> 0). Alpha is straight (unassociated) and never sRGB-encoded. SRGB writes an
 * sRGB chunk; LINEAR writes a gamma chunk of 1.0. Returns OK, INVALID_ARGUMENT, IO_ERROR. */
obs_status io_png_write(obs_context *ctx, const char *path, const obs_image_f32 *planes, int plane_count,
                        io_png_encoding encoding);

/* The sRGB transfer function and its inverse (IEC 61966-2-1), exposed for tests. */
float io_srgb_encode(float linear);
float io_srgb_decode(float encoded);

/* 1 once the image module (OpenImageIO) has been loaded in this process, 0 before (for tests:
 * a process that reads or writes no image never loads it). */
int io_image_module_loaded(void);
/* Load the image module now (it is otherwise loaded by the first image call): OK, or IO_ERROR
 * naming the module and why. For callers that time their first image call. */
obs_status io_image_module_load(obs_context *ctx);


/* ------------------------------------------------------------------------------------------------
 * Volumes (docs/volume.md, "Volumes and loaders"): NIfTI-1/2 (.nii, .nii.gz, .hdr/.img) through
 * nifticlib, NRRD (.nrrd, .nhdr) through teem, and raw files described by options. The grid type
 * is vol_grid (src/volume/vol.h); values are converted to float.
 * ---------------------------------------------------------------------------------------------- */

struct vol_grid;

typedef enum io_volume_format {
    IO_VOLUME_AUTO = 0,   /* from the name: .nii/.nii.gz/.hdr -> NIfTI, .nrrd/.nhdr -> NRRD, else a
                             file starting "NRRD" -> NRRD; raw is never guessed */
    IO_VOLUME_NIFTI,
    IO_VOLUME_NRRD,
    IO_VOLUME_RAW,
    IO_VOLUME_FORMAT_COUNT
} io_volume_format;

typedef struct io_volume_options {
    io_volume_format format;   /* default IO_VOLUME_AUTO */
    /* Raw files only (IO_VOLUME_RAW): */
    int dims[3];               /* nx, ny, nz, each >= 1 (no default: 0 is refused) */
    int type;                  /* a vol_type (VOL_TYPE_U8 ...); default VOL_TYPE_U8 */
    int big_endian;            /* byte order of 16/32-bit samples; default 0 (little endian) */
    double spacing[3];         /* default 1, 1, 1 */
    int64_t header_skip;       /* bytes before the data; default 0 */
} io_volume_options;

io_volume_options io_volume_options_default(void);

/* Load a scalar volume into *out (allocated by the call; free with vol_grid_free). Every size is
 * checked against ctx's max_voxels and max_memory_bytes (the float grid plus the file's samples)
 * and, for uncompressed data, against the file's length before anything is allocated.
 * NIfTI: scl_slope/scl_inter applied when slope != 0; 4D with t > 1, complex/RGB and types other
 * than u8/u16/i16/f32 refused; a rotated or flipped qform/sform is reported through obs_log (WARN)
 * and the stored axes are kept. NRRD: 3D scalar u8/u16/i16/f32, any encoding teem reads; spacing
 * from "spacings" or the lengths of "space directions" (1 when neither). Raw: from the options;
 * a file shorter than header_skip + the data is refused, a longer one is loaded with a warning.
 * Returns OK, INVALID_ARGUMENT (bad options), IO_ERROR (missing, unreadable, truncated),
 * PARSE_ERROR (malformed header, sizes that disagree with the file), UNSUPPORTED (4D, type,
 * non-scalar), LIMIT_EXCEEDED, OUT_OF_MEMORY; messages name the file. On failure *out is empty. */
obs_status io_volume_load(obs_context *ctx, const char *path, const io_volume_options *opts, struct vol_grid *out);

/* Write a grid as an attached, raw, little-endian NRRD (NRRD0004: type float, sizes, spacings;
 * the origin is not stored), atomically. For fixtures and conversions; io_volume_load reads the
 * values and spacing back exactly. Returns OK, INVALID_ARGUMENT, IO_ERROR, OUT_OF_MEMORY. */
obs_status io_volume_write_nrrd(obs_context *ctx, const char *path, const struct vol_grid *g);

#ifdef __cplusplus
}
#endif

#endif /* IO_H */
