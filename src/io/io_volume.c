/* io_volume.c: scalar volumes from NIfTI-1/2 (nifticlib's nifti2_io, which reads both [NIfTI1]),
 * NRRD (teem's nrrdLoad [NRRD]) and raw files; a raw NRRD writer for fixtures and conversions.
 * Conventions and the error contract: io.h, "Volumes"; docs/volume.md, "Volumes and loaders".
 * Order everywhere: read the header only, check every size against the limits and (for
 * uncompressed data) the file's length, then let the library read the samples, then convert. */
#include "io.h"

#include "../volume/vol.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include <nifti2_io.h>
#include <teem/nrrd.h>

io_volume_options io_volume_options_default(void)
{
    io_volume_options o;
    memset(&o, 0, sizeof o);
    o.format = IO_VOLUME_AUTO;
    o.type = VOL_TYPE_U8;
    o.big_endian = 0;
    o.spacing[0] = o.spacing[1] = o.spacing[2] = 1.0;
    o.header_skip = 0;
    return o;
}

/* ---- shared helpers ---------------------------------------------------------------------------- */

static int ends_with(const char *s, const char *suffix)
{
    size_t a = strlen(s), b = strlen(suffix);
    if (b > a)
        return 0;
    for (size_t i = 0; i < b; i++) {
        char c = s[a - b + i];
        if (c >= 'A' && c <= 'Z')
            c = (char)(c - 'A' + 'a');
        if (c != suffix[i])
            return 0;
    }
    return 1;
}

/* File length, or -1 (errno kept) when it cannot be stat'ed. */
static int64_t file_length(const char *path)
{
    struct stat st;
    if (stat(path, &st) != 0)
        return -1;
    return (int64_t)st.st_size;
}

static size_t type_bytes(vol_type t)
{
    return t == VOL_TYPE_U8 ? 1 : t == VOL_TYPE_F32 ? 4 : 2;
}

/* Sizes against the limits before anything is allocated: the voxel count against max_voxels, and
 * the float grid plus the library's copy of the samples (n * src_bytes) against max_memory_bytes
 * (one allocation group, as obs_limits defines it). Dimensions come in as int64 from the headers. */
static obs_status check_sizes(obs_context *ctx, const char *path, int64_t nx, int64_t ny, int64_t nz,
                              size_t src_bytes, size_t *voxels_out)
{
    if (nx < 1 || ny < 1 || nz < 1)
        return obs_error(ctx, OBS_STATUS_PARSE_ERROR, "%s: dimensions %lldx%lldx%lld: each must be >= 1", path,
                         (long long)nx, (long long)ny, (long long)nz);
    obs_limits deflim = obs_limits_default();
    const obs_limits *lim = ctx ? obs_context_limits(ctx) : &deflim;
    double nv = (double)nx * (double)ny * (double)nz;
    if (nx > 2147483647 || ny > 2147483647 || nz > 2147483647 || nv > (double)lim->max_voxels)
        return obs_error(ctx, OBS_STATUS_LIMIT_EXCEEDED,
                         "%s: volume %lldx%lldx%lld has %.6g voxels, over the limit of %lld (raise it with "
                         "--max-voxels)",
                         path, (long long)nx, (long long)ny, (long long)nz, nv, (long long)lim->max_voxels);
    double bytes = nv * (4.0 + (double)src_bytes);
    if (bytes > (double)lim->max_memory_bytes)
        return obs_error(ctx, OBS_STATUS_LIMIT_EXCEEDED,
                         "%s: volume %lldx%lldx%lld needs %.6g bytes to load, over the limit of %lld (raise it "
                         "with --max-memory)",
                         path, (long long)nx, (long long)ny, (long long)nz, bytes, (long long)lim->max_memory_bytes);
    *voxels_out = (size_t)nx * (size_t)ny * (size_t)nz;
    return OBS_STATUS_OK;
}

/* Convert n samples of type t (native byte order unless swap) to floats, v = slope * raw + inter. */
static void convert_samples(const void *src, vol_type t, int swap, size_t n, double slope, double inter, float *dst)
{
    const unsigned char *b = (const unsigned char *)src;
    for (size_t i = 0; i < n; i++) {
        double raw;
        switch (t) {
        case VOL_TYPE_U8:
            raw = b[i];
            break;
        case VOL_TYPE_U16:
        case VOL_TYPE_I16: {
            unsigned char q[2] = {b[2 * i], b[2 * i + 1]};
            if (swap) {
                unsigned char x = q[0];
                q[0] = q[1];
                q[1] = x;
            }
            if (t == VOL_TYPE_U16) {
                uint16_t u;
                memcpy(&u, q, 2);
                raw = u;
            } else {
                int16_t s;
                memcpy(&s, q, 2);
                raw = s;
            }
            break;
        }
        default: {
            unsigned char q[4] = {b[4 * i], b[4 * i + 1], b[4 * i + 2], b[4 * i + 3]};
            if (swap) {
                unsigned char x = q[0];
                q[0] = q[3];
                q[3] = x;
                x = q[1];
                q[1] = q[2];
                q[2] = x;
            }
            float f;
            memcpy(&f, q, 4);
            raw = f;
            break;
        }
        }
        dst[i] = (slope == 1.0 && inter == 0.0) ? (float)raw : (float)(slope * raw + inter);
    }
}

static int host_is_big_endian(void)
{
    const uint16_t one = 1;
    unsigned char c;
    memcpy(&c, &one, 1);
    return c == 0;
}

/* Axis-aligned check of a 3x3 matrix (rows = world axes, columns = voxel axes): each column's
 * off-diagonal entries below 1e-6 of its length and its diagonal positive. */
static int axes_are_kept(const double m[3][3])
{
    for (int c = 0; c < 3; c++) {
        double len = sqrt(m[0][c] * m[0][c] + m[1][c] * m[1][c] + m[2][c] * m[2][c]);
        if (!(len > 0.0) || !(m[c][c] > 0.0))
            return 0;
        for (int r = 0; r < 3; r++)
            if (r != c && fabs(m[r][c]) > 1e-6 * len)
                return 0;
    }
    return 1;
}

static obs_status check_spacing(obs_context *ctx, const char *path, const double sp[3])
{
    for (int a = 0; a < 3; a++)
        if (!isfinite(sp[a]) || !(sp[a] > 0.0))
            return obs_error(ctx, OBS_STATUS_PARSE_ERROR,
                             "%s: voxel spacing (%g, %g, %g): each must be finite and > 0", path, sp[0], sp[1],
                             sp[2]);
    return OBS_STATUS_OK;
}

/* ---- NIfTI ------------------------------------------------------------------------------------- */

static obs_status load_nifti(obs_context *ctx, const char *path, vol_grid *out)
{
    nifti_set_debug_level(0); /* nifticlib prints to stderr otherwise; our messages say it all */
    /* The stored dims first: nifticlib turns a dim[i] < 1 (i <= dim[0]) into 1 silently, while the
     * standard requires dim[i] >= 1 [NIfTI1] (a header with a zero side is a broken file). The raw
     * header may be in the file's byte order: a dim[0] outside 1..7 means swapped. */
    {
        int nver = 0;
        void *raw = nifti_read_header(path, &nver, 0);
        int64_t d[8] = {0};
        int dt = -1;
        if (raw && nver == 1) {
            const nifti_1_header *h1 = (const nifti_1_header *)raw;
            for (int i = 0; i < 8; i++)
                d[i] = h1->dim[i];
            dt = (uint16_t)h1->datatype;
            if (d[0] < 1 || d[0] > 7) {
                for (int i = 0; i < 8; i++)
                    d[i] = (int16_t)(((uint16_t)h1->dim[i] >> 8) | ((uint16_t)h1->dim[i] << 8));
                dt = (uint16_t)(((uint16_t)h1->datatype >> 8) | ((uint16_t)h1->datatype << 8));
            }
        } else if (raw && nver == 2) {
            const nifti_2_header *h2 = (const nifti_2_header *)raw;
            for (int i = 0; i < 8; i++)
                d[i] = h2->dim[i];
            dt = h2->datatype;
            if (d[0] < 1 || d[0] > 7) {
                for (int i = 0; i < 8; i++) {
                    uint64_t u = (uint64_t)h2->dim[i], w = 0;
                    for (int b = 0; b < 8; b++)
                        w |= ((u >> (8 * b)) & 255u) << (8 * (7 - b));
                    d[i] = (int64_t)w;
                }
                dt = (int)(((uint32_t)h2->datatype >> 24) | (((uint32_t)h2->datatype >> 8) & 0xff00u) |
                           (((uint32_t)h2->datatype << 8) & 0xff0000u) | ((uint32_t)h2->datatype << 24));
            }
        }
        free(raw);
        if (dt >= 0 && dt != DT_UINT8 && dt != DT_UINT16 && dt != DT_INT16 && dt != DT_FLOAT32)
            return obs_error(ctx, OBS_STATUS_UNSUPPORTED,
                             "%s: NIfTI datatype %d (%s) is not supported (u8, u16, i16 and f32 are; complex and "
                             "RGB never)",
                             path, dt, nifti_datatype_string(dt));
        if (d[0] >= 1 && d[0] <= 7)
            for (int i = 1; i <= d[0]; i++)
                if (d[i] < 1)
                    return obs_error(ctx, OBS_STATUS_PARSE_ERROR,
                                     "%s: NIfTI dim[%d] = %lld: every dimension up to dim[0] = %lld must be >= 1",
                                     path, i, (long long)d[i], (long long)d[0]);
    }
    nifti_image *nim = nifti_image_read(path, 0);
    if (!nim)
        return obs_error(ctx, OBS_STATUS_PARSE_ERROR,
                         "%s: not a readable NIfTI-1/2 file (nifticlib refused the header: wrong magic or "
                         "sizeof_hdr, a dimension < 1, a bad datatype, or a truncated header)",
                         path);
    obs_status st = OBS_STATUS_OK;
    vol_type t;
    /* Dimensions: 3D, or higher with every extra dimension 1. */
    if (nim->nt > 1 || nim->nu > 1 || nim->nv > 1 || nim->nw > 1) {
        st = obs_error(ctx, OBS_STATUS_UNSUPPORTED,
                       "%s: %lld-D NIfTI (dims %lld %lld %lld %lld %lld %lld %lld): only single 3D volumes are "
                       "supported (t = 1)",
                       path, (long long)nim->dim[0], (long long)nim->nx, (long long)nim->ny, (long long)nim->nz,
                       (long long)nim->nt, (long long)nim->nu, (long long)nim->nv, (long long)nim->nw);
        goto done;
    }
    switch (nim->datatype) {
    case DT_UINT8: t = VOL_TYPE_U8; break;
    case DT_UINT16: t = VOL_TYPE_U16; break;
    case DT_INT16: t = VOL_TYPE_I16; break;
    case DT_FLOAT32: t = VOL_TYPE_F32; break;
    default:
        st = obs_error(ctx, OBS_STATUS_UNSUPPORTED,
                       "%s: NIfTI datatype %d (%s) is not supported (u8, u16, i16 and f32 are; complex and RGB "
                       "never)",
                       path, nim->datatype, nifti_datatype_string(nim->datatype));
        goto done;
    }
    if (nim->nbyper != (int)type_bytes(t)) {
        st = obs_error(ctx, OBS_STATUS_PARSE_ERROR, "%s: bitpix says %d bytes per voxel for datatype %s", path,
                       nim->nbyper, vol_type_name(t));
        goto done;
    }
    int64_t nz = nim->dim[0] >= 3 ? nim->nz : 1, ny = nim->dim[0] >= 2 ? nim->ny : 1;
    size_t nvox;
    st = check_sizes(ctx, path, nim->nx, ny, nz, type_bytes(t), &nvox);
    if (st != OBS_STATUS_OK)
        goto done;
    double sp[3] = {fabs(nim->dx), ny > 1 || nim->dim[0] >= 2 ? fabs(nim->dy) : 1.0,
                    nz > 1 || nim->dim[0] >= 3 ? fabs(nim->dz) : 1.0};
    st = check_spacing(ctx, path, sp);
    if (st != OBS_STATUS_OK)
        goto done;

    /* The file's length, for uncompressed data (a .gz's length says nothing: a short stream is
     * caught by nifticlib's read after the limits above bounded the allocation). */
    if (nim->iname && !ends_with(nim->iname, ".gz")) {
        int64_t len = file_length(nim->iname);
        int64_t need = nim->iname_offset + (int64_t)nvox * (int64_t)nim->nbyper;
        if (len >= 0 && len < need) {
            st = obs_error(ctx, OBS_STATUS_IO_ERROR,
                           "%s: truncated: the header says %lldx%lldx%lld %s voxels from byte %lld (%lld bytes "
                           "in all) but %s has %lld bytes",
                           path, (long long)nim->nx, (long long)ny, (long long)nz, vol_type_name(t),
                           (long long)nim->iname_offset, (long long)need, nim->iname, (long long)len);
            goto done;
        }
    }

    /* Orientation: keep the stored axes; say so when the chosen transform rotates or flips them. */
    const nifti_dmat44 *m = nim->sform_code > 0 ? &nim->sto_xyz : nim->qform_code > 0 ? &nim->qto_xyz : NULL;
    double origin[3] = {0.0, 0.0, 0.0};
    if (m) {
        double r[3][3];
        for (int i = 0; i < 3; i++)
            for (int j = 0; j < 3; j++)
                r[i][j] = m->m[i][j];
        if (axes_are_kept(r)) {
            for (int i = 0; i < 3; i++)
                origin[i] = m->m[i][3];
        } else {
            obs_log(ctx, OBS_LOG_WARN,
                    "%s: the %s transform rotates or flips the voxel axes; obscura keeps the stored axes "
                    "(voxel i along +x, j along +y, k along +z) and puts voxel (0, 0, 0) at the origin",
                    path, nim->sform_code > 0 ? "sform" : "qform");
        }
    }

    if (nifti_image_load(nim) < 0 || !nim->data) {
        st = obs_error(ctx, OBS_STATUS_IO_ERROR,
                       "%s: cannot read the %lldx%lldx%lld %s voxels (truncated or corrupt data)", path,
                       (long long)nim->nx, (long long)ny, (long long)nz, vol_type_name(t));
        goto done;
    }
    st = vol_grid_alloc(ctx, (int)nim->nx, (int)ny, (int)nz, sp, out);
    if (st != OBS_STATUS_OK)
        goto done;
    /* NIfTI-1 section "scl_slope": scaling applies when scl_slope != 0 [NIfTI1]. nifticlib has
     * already swapped the bytes to the host's order. */
    double slope = 1.0, inter = 0.0;
    if (isfinite(nim->scl_slope) && nim->scl_slope != 0.0) {
        slope = nim->scl_slope;
        inter = isfinite(nim->scl_inter) ? nim->scl_inter : 0.0;
    }
    convert_samples(nim->data, t, 0, nvox, slope, inter, out->data);
    for (int i = 0; i < 3; i++)
        out->origin[i] = origin[i];
    out->source_type = t;
    snprintf(out->source, sizeof out->source, "%s", path);
    vol_grid_update_range(out);
done:
    nifti_image_free(nim);
    return st;
}

/* ---- NRRD -------------------------------------------------------------------------------------- */

static obs_status nrrd_error(obs_context *ctx, obs_status st, const char *path, const char *what)
{
    char *err = biffGetDone(NRRD);
    /* teem's messages span lines; keep the last line (the innermost cause) and the first. */
    char first[256] = "", last[256] = "";
    if (err) {
        const char *p = err;
        int line = 0;
        while (*p) {
            const char *e = strchr(p, '\n');
            size_t n = e ? (size_t)(e - p) : strlen(p);
            if (n > 0) {
                snprintf(line == 0 ? first : last, 256, "%.*s", (int)(n < 255 ? n : 255), p);
                line++;
            }
            p += n + (e ? 1 : 0);
        }
        free(err);
    }
    return obs_error(ctx, st, "%s: %s (teem: %s%s%s)", path, what, first, last[0] ? " ... " : "", last);
}

/* Bytes up to and including the blank line that ends an attached NRRD header (0 when not found
 * in the first 1 MiB: then only the data's own length is checked). */
static int64_t nrrd_attached_header_length(const char *path)
{
    FILE *f = fopen(path, "rb");
    if (!f)
        return 0;
    int64_t pos = 0, found = 0;
    int prev = 0, c;
    while (pos < (1 << 20) && (c = fgetc(f)) != EOF) {
        pos++;
        if (c == '\r')
            continue;
        if (c == '\n' && prev == '\n') {
            found = pos;
            break;
        }
        prev = c;
    }
    fclose(f);
    return found;
}

static obs_status load_nrrd(obs_context *ctx, const char *path, vol_grid *out)
{
    obs_status st = OBS_STATUS_OK;
    Nrrd *hdr = nrrdNew(), *nrrd = NULL;
    NrrdIoState *nio = nrrdIoStateNew();
    if (!hdr || !nio) {
        st = obs_error(ctx, OBS_STATUS_OUT_OF_MEMORY, "%s: cannot allocate teem's state", path);
        goto done;
    }
    /* The header only first (teem would allocate the data at once otherwise). */
    nrrdIoStateSet(nio, nrrdIoStateSkipData, AIR_TRUE);
    if (nrrdLoad(hdr, path, nio)) {
        st = nrrd_error(ctx, file_length(path) < 0 ? OBS_STATUS_IO_ERROR : OBS_STATUS_PARSE_ERROR, path,
                        "cannot read the NRRD header");
        goto done;
    }
    if (hdr->dim != 3) {
        st = obs_error(ctx, OBS_STATUS_UNSUPPORTED, "%s: a %u-dimensional NRRD: only 3D scalar volumes are supported",
                       path, hdr->dim);
        goto done;
    }
    vol_type t;
    switch (hdr->type) {
    case nrrdTypeUChar: t = VOL_TYPE_U8; break;
    case nrrdTypeUShort: t = VOL_TYPE_U16; break;
    case nrrdTypeShort: t = VOL_TYPE_I16; break;
    case nrrdTypeFloat: t = VOL_TYPE_F32; break;
    default:
        st = obs_error(ctx, OBS_STATUS_UNSUPPORTED,
                       "%s: NRRD type \"%s\" is not supported (uchar, ushort, short and float are)", path,
                       airEnumStr(nrrdType, hdr->type));
        goto done;
    }
    size_t nvox;
    st = check_sizes(ctx, path, (int64_t)hdr->axis[0].size, (int64_t)hdr->axis[1].size, (int64_t)hdr->axis[2].size,
                     type_bytes(t), &nvox);
    if (st != OBS_STATUS_OK)
        goto done;

    /* Spacing: "spacings", else the lengths of "space directions" (a rotation is reported and the
     * axes kept), else 1. The origin: "space origin" when the directions are axis-aligned. */
    double sp[3], origin[3] = {0.0, 0.0, 0.0}, dirs[3][3];
    int have_dirs = hdr->spaceDim == 3;
    for (int a = 0; a < 3; a++) {
        sp[a] = hdr->axis[a].spacing;
        if (have_dirs) {
            double len = 0.0;
            for (int r = 0; r < 3; r++) {
                dirs[r][a] = hdr->axis[a].spaceDirection[r];
                len += dirs[r][a] * dirs[r][a];
            }
            if (!isfinite(len))
                have_dirs = 0;
            else if (!isfinite(sp[a]))
                sp[a] = sqrt(len);
        }
        if (!isfinite(sp[a])) {
            if (a == 0 || isfinite(sp[0]))
                obs_log(ctx, OBS_LOG_INFO, "%s: no spacing for axis %d: using 1", path, a);
            sp[a] = 1.0;
        }
    }
    st = check_spacing(ctx, path, sp);
    if (st != OBS_STATUS_OK)
        goto done;
    if (have_dirs) {
        if (axes_are_kept(dirs)) {
            for (int a = 0; a < 3; a++)
                origin[a] = isfinite(hdr->spaceOrigin[a]) ? hdr->spaceOrigin[a] : 0.0;
        } else {
            obs_log(ctx, OBS_LOG_WARN,
                    "%s: the space directions rotate or flip the voxel axes; obscura keeps the stored axes "
                    "(voxel i along +x, j along +y, k along +z) and puts voxel (0, 0, 0) at the origin",
                    path);
        }
    }

    /* The file's length, for raw encoding (attached: the data follows the header; detached: one
     * data file after byte skip). */
    if (nio->encoding == nrrdEncodingRaw) {
        int64_t need = (int64_t)(nvox * type_bytes(t));
        const char *df = path;
        int64_t skip = 0;
        char dfbuf[4096];
        if (nio->dataFNArr && nio->dataFNArr->len == 1 && nio->dataFN && nio->dataFN[0]) {
            /* A relative data file is relative to the header's directory (NRRD "data file"). */
            df = nio->dataFN[0];
            const char *slash = strrchr(path, '/');
            if (df[0] != '/' && slash) {
                snprintf(dfbuf, sizeof dfbuf, "%.*s/%s", (int)(slash - path), path, df);
                df = dfbuf;
            }
            skip = nio->byteSkip > 0 ? nio->byteSkip : 0;
        }
        int64_t len = (nio->dataFNArr && nio->dataFNArr->len > 1) ? -1 : file_length(df);
        if (df != path && len < 0 && !(nio->dataFNArr && nio->dataFNArr->len > 1)) {
            st = obs_error(ctx, OBS_STATUS_IO_ERROR, "%s: cannot open its data file %s: %s", path, df,
                           strerror(errno));
            goto done;
        }
        else if (df == path && len >= 0)
            skip = nrrd_attached_header_length(path) + (nio->byteSkip > 0 ? nio->byteSkip : 0);
        if (len >= 0 && len < need + skip) {
            st = obs_error(ctx, OBS_STATUS_IO_ERROR,
                           "%s: truncated: the header says %llux%llux%llu %s voxels (%lld bytes after %lld bytes "
                           "of header or skip) but %s has %lld bytes",
                           path, (unsigned long long)hdr->axis[0].size, (unsigned long long)hdr->axis[1].size,
                           (unsigned long long)hdr->axis[2].size, vol_type_name(t), (long long)need, (long long)skip,
                           df, (long long)len);
            goto done;
        }
    }

    /* The data (teem swaps to the host's byte order and decodes gzip/bzip2). */
    nrrd = nrrdNew();
    if (!nrrd) {
        st = obs_error(ctx, OBS_STATUS_OUT_OF_MEMORY, "%s: cannot allocate teem's state", path);
        goto done;
    }
    if (nrrdLoad(nrrd, path, NULL)) {
        st = nrrd_error(ctx, OBS_STATUS_IO_ERROR, path, "cannot read the NRRD data (truncated or corrupt)");
        goto done;
    }
    if (nrrd->dim != 3 || nrrd->type != hdr->type || nrrd->axis[0].size != hdr->axis[0].size ||
        nrrd->axis[1].size != hdr->axis[1].size || nrrd->axis[2].size != hdr->axis[2].size || !nrrd->data) {
        st = obs_error(ctx, OBS_STATUS_IO_ERROR, "%s: changed while it was being read", path);
        goto done;
    }
    st = vol_grid_alloc(ctx, (int)hdr->axis[0].size, (int)hdr->axis[1].size, (int)hdr->axis[2].size, sp, out);
    if (st != OBS_STATUS_OK)
        goto done;
    convert_samples(nrrd->data, t, 0, nvox, 1.0, 0.0, out->data);
    for (int a = 0; a < 3; a++)
        out->origin[a] = origin[a];
    out->source_type = t;
    snprintf(out->source, sizeof out->source, "%s", path);
    vol_grid_update_range(out);
done:
    if (nio)
        nrrdIoStateNix(nio);
    if (hdr)
        nrrdNuke(hdr);
    if (nrrd)
        nrrdNuke(nrrd);
    return st;
}

/* ---- raw --------------------------------------------------------------------------------------- */

static obs_status load_raw(obs_context *ctx, const char *path, const io_volume_options *o, vol_grid *out)
{
    if (o->type < 0 || o->type >= VOL_TYPE_COUNT)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "%s: raw type %d is not a vol_type (u8, u16, i16, f32)",
                         path, o->type);
    if (o->dims[0] < 1 || o->dims[1] < 1 || o->dims[2] < 1)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "%s: raw dimensions %dx%dx%d: each must be >= 1", path,
                         o->dims[0], o->dims[1], o->dims[2]);
    if (o->header_skip < 0)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "%s: raw header skip %lld is negative", path,
                         (long long)o->header_skip);
    for (int a = 0; a < 3; a++)
        if (!isfinite(o->spacing[a]) || !(o->spacing[a] > 0.0))
            return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT,
                             "%s: raw spacing (%g, %g, %g): each must be finite and > 0", path, o->spacing[0],
                             o->spacing[1], o->spacing[2]);
    vol_type t = (vol_type)o->type;
    size_t nvox;
    obs_status st = check_sizes(ctx, path, o->dims[0], o->dims[1], o->dims[2], type_bytes(t), &nvox);
    if (st != OBS_STATUS_OK)
        return st;
    size_t bytes = nvox * type_bytes(t);
    FILE *f = fopen(path, "rb");
    if (!f)
        return obs_error(ctx, OBS_STATUS_IO_ERROR, "%s: cannot open: %s", path, strerror(errno));
    int64_t len = file_length(path);
    if (len < 0 || len < o->header_skip + (int64_t)bytes) {
        fclose(f);
        return obs_error(ctx, OBS_STATUS_IO_ERROR,
                         "%s: %lld bytes, but %dx%dx%d %s voxels after a %lld-byte header need %lld", path,
                         (long long)len, o->dims[0], o->dims[1], o->dims[2], vol_type_name(t),
                         (long long)o->header_skip, (long long)(o->header_skip + (int64_t)bytes));
    }
    if (len > o->header_skip + (int64_t)bytes)
        obs_log(ctx, OBS_LOG_WARN, "%s: %lld bytes after the %lld the options describe are ignored", path,
                (long long)(len - o->header_skip - (int64_t)bytes), (long long)(o->header_skip + (int64_t)bytes));
    void *buf = malloc(bytes);
    if (!buf) {
        fclose(f);
        return obs_error(ctx, OBS_STATUS_OUT_OF_MEMORY, "%s: cannot allocate %zu bytes", path, bytes);
    }
    if (fseeko(f, (off_t)o->header_skip, SEEK_SET) != 0 || fread(buf, 1, bytes, f) != bytes) {
        free(buf);
        fclose(f);
        return obs_error(ctx, OBS_STATUS_IO_ERROR, "%s: cannot read %zu bytes", path, bytes);
    }
    fclose(f);
    st = vol_grid_alloc(ctx, o->dims[0], o->dims[1], o->dims[2], o->spacing, out);
    if (st == OBS_STATUS_OK) {
        int swap = (o->big_endian != 0) != host_is_big_endian();
        convert_samples(buf, t, swap && t != VOL_TYPE_U8, nvox, 1.0, 0.0, out->data);
        out->source_type = t;
        snprintf(out->source, sizeof out->source, "%s", path);
        vol_grid_update_range(out);
    }
    free(buf);
    return st;
}

/* ---- entry points ------------------------------------------------------------------------------ */

obs_status io_volume_load(obs_context *ctx, const char *path, const io_volume_options *opts, vol_grid *out)
{
    if (!out)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "io_volume_load: out is NULL");
    memset(out, 0, sizeof *out);
    if (!path || !path[0])
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "io_volume_load: no path");
    io_volume_options def = io_volume_options_default();
    const io_volume_options *o = opts ? opts : &def;
    io_volume_format fmt = o->format;
    if ((int)fmt < 0 || fmt >= IO_VOLUME_FORMAT_COUNT)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "%s: unknown volume format %d", path, (int)fmt);
    if (file_length(path) < 0)
        return obs_error(ctx, OBS_STATUS_IO_ERROR, "%s: cannot open: %s", path, strerror(errno));
    if (fmt == IO_VOLUME_AUTO) {
        if (ends_with(path, ".nii") || ends_with(path, ".nii.gz") || ends_with(path, ".hdr") ||
            ends_with(path, ".hdr.gz"))
            fmt = IO_VOLUME_NIFTI;
        else if (ends_with(path, ".nrrd") || ends_with(path, ".nhdr"))
            fmt = IO_VOLUME_NRRD;
        else {
            char magic[4] = {0};
            FILE *f = fopen(path, "rb");
            size_t got = f ? fread(magic, 1, 4, f) : 0;
            if (f)
                fclose(f);
            if (got == 4 && memcmp(magic, "NRRD", 4) == 0)
                fmt = IO_VOLUME_NRRD;
            else
                return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT,
                                 "%s: cannot tell the volume format from the name (.nii, .nii.gz, .hdr, .nrrd, "
                                 ".nhdr); name the format (raw needs dims, type and spacing)",
                                 path);
        }
    }
    obs_status st;
    switch (fmt) {
    case IO_VOLUME_NIFTI: st = load_nifti(ctx, path, out); break;
    case IO_VOLUME_NRRD: st = load_nrrd(ctx, path, out); break;
    default: st = load_raw(ctx, path, o, out); break;
    }
    if (st != OBS_STATUS_OK)
        vol_grid_free(out);
    return st;
}

obs_status io_volume_write_nrrd(obs_context *ctx, const char *path, const vol_grid *g)
{
    if (!path || !g || !g->data || g->nx < 1 || g->ny < 1 || g->nz < 1)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "io_volume_write_nrrd: no path or an empty grid");
    char head[512];
    /* %.17g: spacing reads back to the same double. */
    int hl = snprintf(head, sizeof head,
                      "NRRD0004\n# written by obscura (io_volume_write_nrrd)\ntype: float\ndimension: 3\n"
                      "sizes: %d %d %d\nspacings: %.17g %.17g %.17g\nendian: little\nencoding: raw\n\n",
                      g->nx, g->ny, g->nz, g->spacing[0], g->spacing[1], g->spacing[2]);
    size_t n = (size_t)g->nx * (size_t)g->ny * (size_t)g->nz, total;
    if (hl <= 0 || (size_t)hl >= sizeof head || !obs_add_size(n * 4, (size_t)hl, &total))
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "%s: header too long", path);
    unsigned char *buf = (unsigned char *)malloc(total);
    if (!buf)
        return obs_error(ctx, OBS_STATUS_OUT_OF_MEMORY, "%s: cannot allocate %zu bytes", path, total);
    memcpy(buf, head, (size_t)hl);
    int swap = host_is_big_endian();
    for (size_t i = 0; i < n; i++) {
        unsigned char q[4];
        memcpy(q, &g->data[i], 4);
        for (int b = 0; b < 4; b++)
            buf[(size_t)hl + 4 * i + (size_t)b] = swap ? q[3 - b] : q[b];
    }
    obs_status st = io_write_file_atomic(ctx, path, buf, total);
    free(buf);
    return st;
}
