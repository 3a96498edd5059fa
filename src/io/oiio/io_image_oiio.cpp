// io_image_oiio.cpp: EXR and PNG through OpenImageIO 2.4, behind the C interface of io.h ("Images").
//
// This file is built as a loadable module (obscura_image_oiio.so), not into libobscura_io: loading
// OpenImageIO pulls in about 260 shared libraries and their static initialisers (0.3-0.5 s per
// process here), so src/io/io_image.c loads this module with dlopen the first time an image is
// read or written (docs/io.md, "The image module"). The module links no part of obscura: the host
// hands over the functions it needs (io_image_module.h, io_image_host) and the names below are
// macros onto that table, so the code reads as plain calls.
//
// Every entry point catches every exception: nothing C++ crosses the boundary. Errors name the
// file and carry OpenImageIO's own error text.
//
// Writing: the image goes to io_temp_path() ("<path>.tmp.<pid>.<n>"), which does not end in
// ".exr"/".png"; OpenImageIO picks the plugin from the name given to ImageOutput::create, so we
// create the writer from the format name ("openexr", "png") and then open() the temporary path
// (OIIO 2.4 writers do not check the extension of the file they open). io_commit_temp() renames
// it onto the final path; on any failure the temporary file is removed.
//
// EXR channels: per-channel formats (ImageSpec::channelformats) so that FLOAT channels stay
// float32, HALF channels are stored as half and UINT channels are stored as uint32 (never
// through float, which would lose integers above 2^24). The pixel data is handed to OIIO in
// its native per-channel layout (TypeUnknown), so OIIO performs no conversion. OpenEXR stores
// channels sorted by name, so the reader always maps channels by name, never by position.

#include "../io_image_module.h"

#include <OpenImageIO/filesystem.h>
#include <OpenImageIO/half.h>
#include <OpenImageIO/imageio.h>
#include <OpenImageIO/typedesc.h>

#include <cerrno>
#include <climits>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <new>
#include <set>
#include <string>
#include <sys/stat.h>
#include <unistd.h>
#include <vector>

// The host's functions (io_image_module.h); set once by obs_io_image_module_v1 before any call.
static const io_image_host *g_host;
#define obs_error (g_host->error)
#define obs_log (g_host->log)
#define obs_mul_size (g_host->mul_size)
#define obs_limits_default (g_host->limits_default)
#define obs_context_limits (g_host->context_limits)
#define obs_image_f32_alloc (g_host->image_f32_alloc)
#define obs_image_u32_alloc (g_host->image_u32_alloc)
#define obs_image_f32_free (g_host->image_f32_free)
#define obs_image_u32_free (g_host->image_u32_free)
#define io_temp_path (g_host->temp_path)
#define io_commit_temp (g_host->commit_temp)
#define io_image_free (g_host->image_free)
#define io_srgb_encode (g_host->srgb_encode)

using OIIO::ImageInput;
using OIIO::ImageOutput;
using OIIO::ImageSpec;
using OIIO::TypeDesc;

namespace {

// The temporary path for a writer; io_temp_path's contract is strlen(path)+48 bytes.
obs_status make_temp(obs_context *ctx, const char *path, std::string &tmp)
{
    std::vector<char> buf(std::strlen(path) + 64);
    obs_status st = io_temp_path(ctx, path, buf.data(), buf.size());
    if (st == OBS_STATUS_OK)
        tmp.assign(buf.data());
    return st;
}

std::string oiio_error_text(const std::string &s)
{
    std::string t = s;
    while (!t.empty() && (t.back() == '\n' || t.back() == ' '))
        t.pop_back();
    return t.empty() ? std::string("unknown OpenImageIO error") : t;
}

// Create the writer for `format`, open `tmp`, write the native-layout data, close it, and
// commit it onto `path`. Removes tmp on every failure.
obs_status write_with_oiio(obs_context *ctx, const char *format, const char *path, const std::string &tmp,
                           const ImageSpec &spec, TypeDesc data_type, const void *data)
{
    auto out = ImageOutput::create(format);
    if (!out)
        return obs_error(ctx, OBS_STATUS_IO_ERROR, "cannot write '%s': no OpenImageIO writer for %s: %s", path,
                         format, oiio_error_text(OIIO::geterror()).c_str());
    if (!out->open(tmp, spec)) {
        std::string err = oiio_error_text(out->geterror());
        out.reset();
        unlink(tmp.c_str());
        return obs_error(ctx, OBS_STATUS_IO_ERROR, "cannot write '%s' (opening '%s'): %s", path, tmp.c_str(),
                         err.c_str());
    }
    bool ok = out->write_image(data_type, data);
    std::string err = ok ? std::string() : oiio_error_text(out->geterror());
    bool closed = out->close();
    if (ok && !closed) {
        ok = false;
        err = oiio_error_text(out->geterror());
    }
    out.reset();
    if (!ok) {
        unlink(tmp.c_str());
        return obs_error(ctx, OBS_STATUS_IO_ERROR, "cannot write '%s' (writing '%s'): %s", path, tmp.c_str(),
                         err.c_str());
    }
    return io_commit_temp(ctx, tmp.c_str(), path);
}

char *dup_cstr(const char *s)
{
    size_t n = std::strlen(s);
    char *d = static_cast<char *>(std::malloc(n + 1));
    if (d)
        std::memcpy(d, s, n + 1);
    return d;
}

// Convert one base value of `base` type at p to double / int64.
double base_to_double(TypeDesc::BASETYPE base, const unsigned char *p)
{
    switch (base) {
    case TypeDesc::UINT8: return *reinterpret_cast<const uint8_t *>(p);
    case TypeDesc::INT8: return *reinterpret_cast<const int8_t *>(p);
    case TypeDesc::UINT16: return *reinterpret_cast<const uint16_t *>(p);
    case TypeDesc::INT16: return *reinterpret_cast<const int16_t *>(p);
    case TypeDesc::UINT32: return *reinterpret_cast<const uint32_t *>(p);
    case TypeDesc::INT32: return *reinterpret_cast<const int32_t *>(p);
    case TypeDesc::UINT64: return (double)*reinterpret_cast<const uint64_t *>(p);
    case TypeDesc::INT64: return (double)*reinterpret_cast<const int64_t *>(p);
    case TypeDesc::HALF: return (float)*reinterpret_cast<const half *>(p);
    case TypeDesc::FLOAT: return *reinterpret_cast<const float *>(p);
    case TypeDesc::DOUBLE: return *reinterpret_cast<const double *>(p);
    default: return NAN;
    }
}

bool base_is_integer(TypeDesc::BASETYPE b)
{
    return b == TypeDesc::UINT8 || b == TypeDesc::INT8 || b == TypeDesc::UINT16 || b == TypeDesc::INT16 ||
           b == TypeDesc::UINT32 || b == TypeDesc::INT32 || b == TypeDesc::UINT64 || b == TypeDesc::INT64;
}

bool base_is_float(TypeDesc::BASETYPE b)
{
    return b == TypeDesc::HALF || b == TypeDesc::FLOAT || b == TypeDesc::DOUBLE;
}

int64_t base_to_int64(TypeDesc::BASETYPE base, const unsigned char *p)
{
    switch (base) {
    case TypeDesc::UINT8: return *reinterpret_cast<const uint8_t *>(p);
    case TypeDesc::INT8: return *reinterpret_cast<const int8_t *>(p);
    case TypeDesc::UINT16: return *reinterpret_cast<const uint16_t *>(p);
    case TypeDesc::INT16: return *reinterpret_cast<const int16_t *>(p);
    case TypeDesc::UINT32: return *reinterpret_cast<const uint32_t *>(p);
    case TypeDesc::INT32: return *reinterpret_cast<const int32_t *>(p);
    case TypeDesc::UINT64: {
        uint64_t u = *reinterpret_cast<const uint64_t *>(p);
        return u > (uint64_t)INT64_MAX ? INT64_MAX : (int64_t)u;
    }
    case TypeDesc::INT64: return *reinterpret_cast<const int64_t *>(p);
    default: return 0;
    }
}

// Convert one OIIO attribute to an io_attr. Returns false (attribute skipped) for types with no
// io_attr equivalent (pointers, unknown) or names that do not fit io_attr::name.
//   strings               -> STRING (string arrays: elements joined with "\n")
//   one integer           -> INT
//   one float/half/double -> FLOAT
//   a 4x4 matrix          -> MATRIX44 (float or double in the file; the 16 values in file order)
//   anything else numeric -> FLOATS (all base values, in order, converted to float;
//                            integers above 2^24 lose precision there)
bool convert_attr(const OIIO::ParamValue &p, io_attr *a, bool *oom)
{
    std::memset(a, 0, sizeof *a);
    std::string name = p.name().string();
    if (name.empty() || name.size() >= sizeof a->name)
        return false;
    TypeDesc t = p.type();
    const unsigned char *data = static_cast<const unsigned char *>(p.data());
    if (!data)
        return false;
    size_t count = (size_t)p.nvalues() * t.basevalues();
    auto base = (TypeDesc::BASETYPE)t.basetype;
    std::memcpy(a->name, name.c_str(), name.size() + 1);

    if (base == TypeDesc::STRING) {
        std::string s;
        const char *const *strs = reinterpret_cast<const char *const *>(data);
        for (size_t i = 0; i < count; i++) {
            if (i)
                s += '\n';
            if (strs[i])
                s += strs[i];
        }
        a->type = IO_ATTR_STRING;
        a->s = dup_cstr(s.c_str());
        if (!a->s)
            *oom = true;
        return a->s != nullptr;
    }
    if (!base_is_integer(base) && !base_is_float(base))
        return false;
    size_t esize = TypeDesc(base).size();
    if (count == 1 && base_is_integer(base)) {
        a->type = IO_ATTR_INT;
        a->i = base_to_int64(base, data);
        return true;
    }
    if (count == 1) {
        a->type = IO_ATTR_FLOAT;
        a->f = (float)base_to_double(base, data);
        return true;
    }
    if (count == 0 || count > (size_t)INT_MAX)
        return false;
    bool is_m44 = p.nvalues() == 1 && t.aggregate == TypeDesc::MATRIX44 && !t.is_array() && base_is_float(base);
    a->type = is_m44 ? IO_ATTR_MATRIX44 : IO_ATTR_FLOATS;
    a->n = (int)count;
    a->v = static_cast<float *>(std::malloc(count * sizeof(float)));
    if (!a->v) {
        *oom = true;
        return false;
    }
    for (size_t i = 0; i < count; i++)
        a->v[i] = (float)base_to_double(base, data + i * esize);
    return true;
}

// ---- EXR header pre-check ---------------------------------------------------------------------
// OpenEXR 3.1 trusts an EXR header's sizes: it allocates a string attribute's declared size
// before reading it (a 65-byte file declaring a 1.6 GB "capDate" made every reader, iinfo too,
// take 1.7 GB and 5 s before "unexpected end of file"), reads string vectors, previews and chunk
// offset tables of whatever size they declare, and parses a channel list past its declared size,
// after which it reads the following bytes as other attributes (found by fuzz_exr,
// docs/reliability.md). So before OpenImageIO sees an EXR, this walks its header(s) as OpenEXR
// does (magic, version flags, then per part "name\0type\0<int32 size><value>" ending with an
// empty name) and refuses, as PARSE_ERROR, what OpenEXR would read beyond the file or out of step
// with the declared sizes: a value larger than the rest of the file, a known type with another
// size than its own, a channel list, preview or string vector that does not fill its size
// exactly, and more chunk offsets than the file can hold; a data window over max_image_pixels is
// LIMIT_EXCEEDED. Anything else malformed is left to OpenEXR to report.

struct ExrBytes {
    const unsigned char *mem; // memory source, or
    FILE *f;                  // file source
    uint64_t size;
    bool read(uint64_t off, void *dst, size_t n) const
    {
        if (off > size || n > size - off)
            return false;
        if (mem) {
            std::memcpy(dst, mem + off, n);
            return true;
        }
        return fseeko(f, (off_t)off, SEEK_SET) == 0 && std::fread(dst, 1, n, f) == n;
    }
    bool le32(uint64_t off, int32_t *v) const
    {
        unsigned char p[4];
        if (!read(off, p, 4))
            return false;
        *v = (int32_t)((uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 | (uint32_t)p[3] << 24);
        return true;
    }
};

// A NUL-terminated name of at most 255 bytes (OpenEXR's Name::SIZE) at *pos into out[256];
// false when it does not end within 256 bytes or the file.
bool exr_cstr(const ExrBytes &b, uint64_t *pos, char out[256])
{
    for (int k = 0; k < 256; k++) {
        unsigned char c;
        if (!b.read(*pos, &c, 1))
            return false;
        ++*pos;
        out[k] = (char)c;
        if (!c)
            return true;
    }
    return false;
}

// The size OpenEXR 3.1 reads for a fixed-size attribute type, or -1 (variable or unknown).
int exr_fixed_size(const char *type)
{
    static const struct { const char *type; int size; } fixed[] = {
        {"box2i", 16}, {"box2f", 16}, {"chromaticities", 32}, {"compression", 1}, {"deepImageState", 1},
        {"double", 8}, {"envmap", 1}, {"float", 4}, {"int", 4}, {"keycode", 28}, {"lineOrder", 1},
        {"m33f", 36}, {"m33d", 72}, {"m44f", 64}, {"m44d", 128}, {"rational", 8}, {"tiledesc", 9},
        {"timecode", 8}, {"v2i", 8}, {"v2f", 8}, {"v2d", 16}, {"v3i", 12}, {"v3f", 12}, {"v3d", 24},
    };
    for (const auto &f : fixed)
        if (!std::strcmp(type, f.type))
            return f.size;
    return -1;
}

// Whether the structured value of a variable-size type fills exactly [pos, end).
bool exr_value_fills(const ExrBytes &b, const char *type, uint64_t pos, uint64_t end)
{
    if (!std::strcmp(type, "chlist")) { // channels "name\0" + 16 bytes, then a NUL
        for (;;) {
            char name[256];
            if (!exr_cstr(b, &pos, name) || pos > end)
                return false;
            if (!name[0])
                return pos == end;
            pos += 16;
            if (pos > end)
                return false;
        }
    }
    if (!std::strcmp(type, "preview")) { // width, height, then 4 bytes per pixel
        int32_t w, h;
        if (end - pos < 8 || !b.le32(pos, &w) || !b.le32(pos + 4, &h))
            return false;
        return (uint64_t)(uint32_t)w * (uint32_t)h * 4 == end - pos - 8;
    }
    if (!std::strcmp(type, "stringvector")) { // (int32 length, bytes)*
        while (pos < end) {
            int32_t n;
            if (end - pos < 4 || !b.le32(pos, &n) || n < 0 || (uint64_t)n > end - pos - 4)
                return false;
            pos += 4 + (uint64_t)n;
        }
        return true;
    }
    return true; // string, floatvector, idmanifest, opaque types: read as `size` bytes
}

obs_status exr_precheck(obs_context *ctx, const char *path, const ExrBytes &b)
{
    unsigned char head[8];
    if (!b.read(0, head, 8) || head[0] != 0x76 || head[1] != 0x2f || head[2] != 0x31 || head[3] != 0x01 ||
        head[4] != 2)
        return OBS_STATUS_OK; // not an EXR, or a version OpenEXR refuses itself
    const bool multipart = (head[5] & 0x10) != 0, tiled_file = (head[5] & 0x02) != 0;
    const obs_limits *lim = obs_context_limits(ctx);
    const int64_t max_px = lim ? lim->max_image_pixels : obs_limits_default().max_image_pixels;
    uint64_t pos = 8, offsets = 0;
    for (int part = 0; part < (1 << 20); part++) {
        int attrs = 0, compression = 0;
        int64_t w = 0, h = 0, tile_w = 0, tile_h = 0, chunk_count = -1;
        for (;;) {
            char name[256], type[256];
            if (!exr_cstr(b, &pos, name))
                return OBS_STATUS_OK;
            if (!name[0])
                break; // the end of this header
            attrs++;
            int32_t size;
            if (!exr_cstr(b, &pos, type) || !b.le32(pos, &size) || size < 0)
                return OBS_STATUS_OK;
            pos += 4;
            if ((uint64_t)size > b.size - pos)
                return obs_error(ctx, OBS_STATUS_PARSE_ERROR,
                                 "cannot read image '%s': EXR attribute '%s' (%s) declares %d bytes, but only %llu "
                                 "bytes are left in the file",
                                 path, name, type, size, (unsigned long long)(b.size - pos));
            const int fixed = exr_fixed_size(type);
            if ((fixed >= 0 && size != fixed) || !exr_value_fills(b, type, pos, pos + (uint64_t)size))
                return obs_error(ctx, OBS_STATUS_PARSE_ERROR,
                                 "cannot read image '%s': EXR attribute '%s' (%s) does not fill its declared %d bytes",
                                 path, name, type, size);
            int32_t v[4];
            if (!std::strcmp(name, "dataWindow") && !std::strcmp(type, "box2i") && b.le32(pos, &v[0]) &&
                b.le32(pos + 4, &v[1]) && b.le32(pos + 8, &v[2]) && b.le32(pos + 12, &v[3])) {
                w = (int64_t)v[2] - v[0] + 1;
                h = (int64_t)v[3] - v[1] + 1;
                if (w > 0 && h > 0 && (w > max_px / h || w * h > max_px))
                    return obs_error(ctx, OBS_STATUS_LIMIT_EXCEEDED,
                                     "image '%s' is %lldx%lld (EXR dataWindow), over the limit of %lld pixels "
                                     "(raise it with --max-pixels)",
                                     path, (long long)w, (long long)h, (long long)max_px);
            } else if (!std::strcmp(name, "compression") && !std::strcmp(type, "compression")) {
                unsigned char c;
                if (b.read(pos, &c, 1))
                    compression = c;
            } else if (!std::strcmp(name, "tiles") && !std::strcmp(type, "tiledesc") && b.le32(pos, &v[0]) &&
                       b.le32(pos + 4, &v[1])) {
                tile_w = (uint32_t)v[0];
                tile_h = (uint32_t)v[1];
            } else if (!std::strcmp(name, "chunkCount") && !std::strcmp(type, "int") && b.le32(pos, &v[0])) {
                chunk_count = v[0];
            }
            pos += (uint64_t)size;
        }
        if (multipart && attrs == 0)
            break; // the empty header that ends a multi-part file's list
        // the chunk offset table OpenEXR will read for this part (level 0 only for tiles)
        static const int lines_per_chunk[] = {1, 1, 1, 16, 32, 16, 32, 32, 32, 256};
        int64_t chunks = 0;
        if (w > 0 && h > 0) {
            if (tile_w > 0 && tile_h > 0 && (tiled_file || multipart))
                chunks = ((w + tile_w - 1) / tile_w) * ((h + tile_h - 1) / tile_h);
            else if (compression >= 0 && compression < 10)
                chunks = (h + lines_per_chunk[compression] - 1) / lines_per_chunk[compression];
        }
        offsets += (uint64_t)(chunk_count > chunks ? chunk_count : chunks);
        if (!multipart)
            break;
    }
    if (offsets > (b.size - pos) / 8)
        return obs_error(ctx, OBS_STATUS_PARSE_ERROR,
                         "cannot read image '%s': the EXR header calls for %llu chunk offsets (%llu bytes), but only "
                         "%llu bytes follow it",
                         path, (unsigned long long)offsets, (unsigned long long)offsets * 8,
                         (unsigned long long)(b.size - pos));
    return OBS_STATUS_OK;
}

// PNG: libpng 1.6 (Debian 12, as OpenImageIO 2.4 drives it) allocates and clears a chunk's declared
// length before reading it: a 144-byte PNG whose tEXt chunk declared 2,003,133,040 bytes took 2 GB
// and 14 s to fail (found by fuzz_exr). Walk the chunks (8-byte signature, then per chunk a
// big-endian length, a type, the data and a CRC, up to IEND) and refuse a chunk longer than the
// rest of the file. Anything else malformed is left to libpng to report.
obs_status png_precheck(obs_context *ctx, const char *path, const ExrBytes &b)
{
    static const unsigned char sig[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
    unsigned char head[8];
    if (!b.read(0, head, 8) || std::memcmp(head, sig, 8) != 0)
        return OBS_STATUS_OK;
    uint64_t pos = 8;
    while (pos < b.size) {
        unsigned char c[8];
        if (!b.read(pos, c, 8))
            return OBS_STATUS_OK; // a truncated chunk header: libpng reports it
        const uint64_t len = (uint64_t)c[0] << 24 | (uint64_t)c[1] << 16 | (uint64_t)c[2] << 8 | c[3];
        char type[5] = {(char)c[4], (char)c[5], (char)c[6], (char)c[7], '\0'};
        for (int k = 0; k < 4; k++)
            if (!((type[k] >= 'A' && type[k] <= 'Z') || (type[k] >= 'a' && type[k] <= 'z')))
                type[k] = '?';
        if (len > b.size - pos - 8 || b.size - pos - 8 - len < 4)
            return obs_error(ctx, OBS_STATUS_PARSE_ERROR,
                             "cannot read image '%s': PNG chunk '%s' at offset %llu declares %llu bytes, but only "
                             "%llu bytes are left in the file",
                             path, type, (unsigned long long)pos, (unsigned long long)len,
                             (unsigned long long)(b.size - pos - 8));
        if (!std::memcmp(c + 4, "IEND", 4))
            break;
        pos += 12 + len;
    }
    return OBS_STATUS_OK;
}

// OpenImageIO 2.4.7's IOMemReader::pread tests `size + size_t(offset) > buffer size`, which wraps
// around for a negative offset: a corrupt EXR chunk offset of -1 made OpenEXR read the byte before
// the caller's buffer (heap-buffer-overflow, found by fuzz_exr). This reader bounds every access.
class BoundedMemReader final : public OIIO::Filesystem::IOMemReader {
public:
    BoundedMemReader(const void *buf, size_t size) : IOMemReader(buf, size) {}
    bool seek(int64_t offset) override
    {
        if (offset < 0)
            return false;
        m_pos = offset;
        return true;
    }
    size_t read(void *buf, size_t n) override
    {
        n = pread(buf, n, m_pos);
        m_pos += (int64_t)n;
        return n;
    }
    size_t pread(void *buf, size_t n, int64_t offset) override
    {
        const size_t len = m_buf.size();
        if (offset < 0 || (uint64_t)offset >= len)
            return 0;
        if (n > len - (size_t)offset)
            n = len - (size_t)offset;
        if (n)
            std::memcpy(buf, m_buf.data() + offset, n);
        return n;
    }
};

// Both pre-checks (each ignores other formats).
obs_status header_precheck(obs_context *ctx, const char *path, const ExrBytes &b)
{
    obs_status st = exr_precheck(ctx, path, b);
    return st != OBS_STATUS_OK ? st : png_precheck(ctx, path, b);
}

} // namespace

static obs_status oiio_exr_write(obs_context *ctx, const char *path, const io_channel *channels, int channel_count,
                        const io_attr *attrs, int attr_count)
{
    try {
        if (!path || !path[0] || !channels || channel_count < 1 || attr_count < 0 || (attr_count > 0 && !attrs))
            return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "io_exr_write: NULL or empty argument");
        int w = 0, h = 0;
        std::set<std::string> seen;
        std::vector<TypeDesc> formats;
        std::vector<size_t> offsets;
        size_t pixel_bytes = 0;
        for (int c = 0; c < channel_count; c++) {
            const io_channel &ch = channels[c];
            if (!ch.name || !ch.name[0])
                return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "cannot write '%s': channel %d has no name", path, c);
            if (!seen.insert(ch.name).second)
                return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "cannot write '%s': channel name '%s' appears twice",
                                 path, ch.name);
            int cw, chh;
            const void *cdata;
            ptrdiff_t cstride;
            TypeDesc fmt;
            if (ch.type == IO_PIXEL_FLOAT || ch.type == IO_PIXEL_HALF) {
                if (!ch.f32 || ch.u32)
                    return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT,
                                     "cannot write '%s': channel '%s' is float/half but has no (or also a uint) plane",
                                     path, ch.name);
                cw = ch.f32->width, chh = ch.f32->height, cdata = ch.f32->data, cstride = ch.f32->stride;
                fmt = ch.type == IO_PIXEL_FLOAT ? TypeDesc(TypeDesc::FLOAT) : TypeDesc(TypeDesc::HALF);
            } else if (ch.type == IO_PIXEL_UINT) {
                if (!ch.u32 || ch.f32)
                    return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT,
                                     "cannot write '%s': channel '%s' is uint but has no (or also a float) plane", path,
                                     ch.name);
                cw = ch.u32->width, chh = ch.u32->height, cdata = ch.u32->data, cstride = ch.u32->stride;
                fmt = TypeDesc(TypeDesc::UINT32);
            } else {
                return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "cannot write '%s': channel '%s' has an invalid type %d",
                                 path, ch.name, (int)ch.type);
            }
            if (!cdata || cw < 1 || chh < 1 || cstride < cw)
                return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT,
                                 "cannot write '%s': channel '%s' has an empty plane or a bad stride", path, ch.name);
            if (c == 0)
                w = cw, h = chh;
            else if (cw != w || chh != h)
                return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT,
                                 "cannot write '%s': channel '%s' is %dx%d but channel '%s' is %dx%d", path, ch.name, cw,
                                 chh, channels[0].name, w, h);
            formats.push_back(fmt);
            offsets.push_back(pixel_bytes);
            pixel_bytes += fmt.size();
        }

        size_t total;
        if (!obs_mul_size((size_t)w, (size_t)h, &total) || !obs_mul_size(total, pixel_bytes, &total))
            return obs_error(ctx, OBS_STATUS_LIMIT_EXCEEDED, "cannot write '%s': %dx%d x %d channels overflows", path, w,
                             h, channel_count);

        ImageSpec spec(w, h, channel_count, TypeDesc::FLOAT);
        spec.channelnames.clear();
        for (int c = 0; c < channel_count; c++)
            spec.channelnames.emplace_back(channels[c].name);
        spec.channelformats = formats;
        spec.alpha_channel = -1;
        spec.z_channel = -1;
        spec.attribute("compression", "zip");
        // OIIO stamps EXRs with the current time (capDate) unless "DateTime" is given, which
        // would make two renders of the same scene differ byte for byte. Default it to an empty
        // string (a caller's own "DateTime" attribute, set below, wins).
        spec.attribute("DateTime", "");

        for (int i = 0; i < attr_count; i++) {
            const io_attr &a = attrs[i];
            if (!a.name[0] || !std::memchr(a.name, '\0', sizeof a.name))
                return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "cannot write '%s': attribute %d has no valid name",
                                 path, i);
            switch (a.type) {
            case IO_ATTR_STRING:
                if (!a.s)
                    return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "cannot write '%s': string attribute '%s' is NULL",
                                     path, a.name);
                spec.attribute(a.name, a.s);
                break;
            case IO_ATTR_FLOAT: spec.attribute(a.name, a.f); break;
            case IO_ATTR_INT:
                // EXR int attributes are 32-bit.
                if (a.i < INT_MIN || a.i > INT_MAX)
                    return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT,
                                     "cannot write '%s': int attribute '%s' = %lld does not fit EXR's 32-bit int", path,
                                     a.name, (long long)a.i);
                spec.attribute(a.name, (int)a.i);
                break;
            case IO_ATTR_MATRIX44:
                // Memory order: our 16 floats go into the file in the order given. We pass a
                // column-major obs_mat4 (m[col*4+row], column vectors: p' = M p); read as the
                // EXR/Imath m44f x[i][j] = m[i*4+j], that is M transposed, which is exactly the
                // conventional row-vector form Imath uses (p' = p * M^T, translation in x[3][0..2]).
                // So an obs_mat4 world-to-camera matrix written as-is is a standard EXR
                // "worldToCamera". Reading gives the same 16 floats back in the same order.
                if (!a.v)
                    return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "cannot write '%s': matrix attribute '%s' is NULL",
                                     path, a.name);
                spec.attribute(a.name, OIIO::TypeMatrix44, a.v);
                break;
            case IO_ATTR_FLOATS:
                if (a.n < 1 || !a.v)
                    return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT,
                                     "cannot write '%s': float array attribute '%s' is empty or NULL", path, a.name);
                spec.attribute(a.name, TypeDesc(TypeDesc::FLOAT, a.n), a.v);
                break;
            default:
                return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "cannot write '%s': attribute '%s' has invalid type %d",
                                 path, a.name, (int)a.type);
            }
        }

        // Interleave into the native per-channel layout: float32 as is, half converted here
        // (round to nearest even, Imath), uint32 as is.
        std::vector<unsigned char> buf(total);
        for (int c = 0; c < channel_count; c++) {
            const io_channel &ch = channels[c];
            for (int y = 0; y < h; y++) {
                unsigned char *dst = buf.data() + (size_t)y * w * pixel_bytes + offsets[c];
                if (ch.type == IO_PIXEL_FLOAT) {
                    const float *src = obs_image_f32_row(ch.f32, y);
                    for (int x = 0; x < w; x++)
                        std::memcpy(dst + (size_t)x * pixel_bytes, &src[x], 4);
                } else if (ch.type == IO_PIXEL_HALF) {
                    const float *src = obs_image_f32_row(ch.f32, y);
                    for (int x = 0; x < w; x++) {
                        half hv(src[x]);
                        std::memcpy(dst + (size_t)x * pixel_bytes, &hv, 2);
                    }
                } else {
                    const uint32_t *src = obs_image_u32_row(ch.u32, y);
                    for (int x = 0; x < w; x++)
                        std::memcpy(dst + (size_t)x * pixel_bytes, &src[x], 4);
                }
            }
        }

        std::string tmp;
        obs_status st = make_temp(ctx, path, tmp);
        if (st != OBS_STATUS_OK)
            return st;
        return write_with_oiio(ctx, "openexr", path, tmp, spec, TypeDesc::UNKNOWN, buf.data());
    } catch (const std::bad_alloc &) {
        return obs_error(ctx, OBS_STATUS_OUT_OF_MEMORY, "out of memory writing '%s'", path ? path : "(null)");
    } catch (const std::exception &e) {
        return obs_error(ctx, OBS_STATUS_IO_ERROR, "cannot write '%s': %s", path ? path : "(null)", e.what());
    } catch (...) {
        return obs_error(ctx, OBS_STATUS_INTERNAL, "cannot write '%s': unknown exception", path ? path : "(null)");
    }
}

// Reads subimage 0, MIP level 0, its data window (spec.x/spec.y offsets are not reported).
// Pixel values are those stored in the file (alpha is never multiplied in: the reader is opened
// with "oiio:UnassociatedAlpha" = 1). Every channel is decoded once in its native type and
// converted plane by plane: UINT32
// channels to uint32 planes, everything else to float32 planes (8/16-bit integer formats such
// as PNG are normalised to [0,1] by OIIO, half is widened exactly). NaN and Inf pass through.
// The reader shared by io_image_read (proxy NULL: OIIO opens `path`) and io_image_read_memory
// (proxy: OIIO reads the bytes through it; `open_name`'s extension picks the plugin, `path` names
// the bytes in messages).
static obs_status read_image(obs_context *ctx, const char *path, const char *open_name,
                             OIIO::Filesystem::IOProxy *proxy, io_image *out)
{
    io_image im;
    std::memset(&im, 0, sizeof im);
    try {
        if (!proxy) {
            // Distinguish "cannot open" (IO_ERROR) from "OpenImageIO cannot make sense of it" (PARSE_ERROR).
            FILE *probe = std::fopen(path, "rb");
            if (!probe) {
                int e = errno;
                return obs_error(ctx, OBS_STATUS_IO_ERROR, "cannot open image '%s': %s", path, std::strerror(e));
            }
            std::fclose(probe);
            struct stat sb;
            if (stat(path, &sb) == 0 && S_ISDIR(sb.st_mode))
                return obs_error(ctx, OBS_STATUS_IO_ERROR, "cannot open image '%s': %s", path, std::strerror(EISDIR));
        }

        // Return the values stored in the file: without this, OIIO multiplies the colour of
        // PNG/TIFF images with unassociated alpha by alpha on reading.
        ImageSpec config;
        config.attribute("oiio:UnassociatedAlpha", 1);
        // OIIO 2.4.7 ignores the ioproxy argument of ImageInput::open ("Could not open file");
        // the "oiio:ioproxy" configuration attribute works.
        if (proxy)
            config.attribute("oiio:ioproxy", TypeDesc::PTR, &proxy);
        auto in = ImageInput::open(open_name, &config);
        if (!in)
            return obs_error(ctx, OBS_STATUS_PARSE_ERROR, "cannot read image '%s': %s", path,
                             oiio_error_text(OIIO::geterror()).c_str());
        const ImageSpec spec = in->spec();
        const int w = spec.width, h = spec.height, nch = spec.nchannels;
        if (spec.deep)
            return obs_error(ctx, OBS_STATUS_UNSUPPORTED, "cannot read image '%s': deep images are not supported", path);
        if (spec.depth > 1)
            return obs_error(ctx, OBS_STATUS_UNSUPPORTED, "cannot read image '%s': volume images (depth %d) are not supported",
                             path, spec.depth);
        if (w < 1 || h < 1 || nch < 1)
            return obs_error(ctx, OBS_STATUS_PARSE_ERROR, "cannot read image '%s': empty image (%dx%d, %d channels)", path,
                             w, h, nch);
        const obs_limits *lim = obs_context_limits(ctx);
        int64_t max_px = lim ? lim->max_image_pixels : obs_limits_default().max_image_pixels;
        int64_t max_mem = lim ? lim->max_memory_bytes : obs_limits_default().max_memory_bytes;
        // w*h < 2^62 fits int64; dividing first keeps px*nch from overflowing.
        int64_t px = (int64_t)w * (int64_t)h;
        if (px > max_px / nch || px * nch > max_px)
            return obs_error(ctx, OBS_STATUS_LIMIT_EXCEEDED,
                             "image '%s' is %dx%d with %d channels = %lld values, over the limit of %lld "
                             "(raise it with --max-pixels)",
                             path, w, h, nch, (long long)px * nch, (long long)max_px);
        size_t pixel_bytes = spec.pixel_bytes(true);
        size_t native_bytes;
        if (pixel_bytes == 0 || !obs_mul_size((size_t)px, pixel_bytes, &native_bytes))
            return obs_error(ctx, OBS_STATUS_LIMIT_EXCEEDED, "image '%s': size overflows", path);
        // Planes (4 bytes per value, rows padded to 64 bytes) plus the native decode buffer.
        int64_t planes_bytes = (int64_t)nch * h * (((int64_t)w + 15) / 16 * 16) * 4;
        if (planes_bytes > max_mem || (int64_t)native_bytes > max_mem - planes_bytes)
            return obs_error(ctx, OBS_STATUS_LIMIT_EXCEEDED,
                             "image '%s' (%dx%d, %d channels) needs about %lld bytes, over the memory limit of %lld "
                             "(raise it with --max-memory)",
                             path, w, h, nch, (long long)(planes_bytes + (int64_t)native_bytes), (long long)max_mem);

        im.width = w;
        im.height = h;
        im.channel_count = nch;
        im.names = static_cast<char (*)[64]>(std::calloc((size_t)nch, sizeof *im.names));
        im.types = static_cast<io_pixel_type *>(std::calloc((size_t)nch, sizeof *im.types));
        im.f32 = static_cast<obs_image_f32 *>(std::calloc((size_t)nch, sizeof *im.f32));
        im.u32 = static_cast<obs_image_u32 *>(std::calloc((size_t)nch, sizeof *im.u32));
        if (!im.names || !im.types || !im.f32 || !im.u32) {
            io_image_free(&im);
            return obs_error(ctx, OBS_STATUS_OUT_OF_MEMORY, "out of memory reading '%s'", path);
        }
        for (int c = 0; c < nch; c++) {
            std::string n = c < (int)spec.channelnames.size() ? spec.channelnames[c] : std::string();
            if (n.empty() || n.size() >= sizeof im.names[0]) {
                io_image_free(&im);
                return obs_error(ctx, OBS_STATUS_PARSE_ERROR, "image '%s': channel %d has an empty or too long name (%zu bytes)",
                                 path, c, n.size());
            }
            for (int d = 0; d < c; d++)
                if (n == im.names[d]) {
                    io_image_free(&im);
                    return obs_error(ctx, OBS_STATUS_PARSE_ERROR, "image '%s': channel name '%s' appears twice", path,
                                     n.c_str());
                }
            std::memcpy(im.names[c], n.c_str(), n.size() + 1);
            TypeDesc f = spec.channelformat(c);
            im.types[c] = f.basetype == TypeDesc::UINT32 ? IO_PIXEL_UINT : IO_PIXEL_FLOAT;
            obs_status st = im.types[c] == IO_PIXEL_UINT ? obs_image_u32_alloc(ctx, w, h, &im.u32[c])
                                                         : obs_image_f32_alloc(ctx, w, h, &im.f32[c]);
            if (st != OBS_STATUS_OK) {
                io_image_free(&im);
                return st;
            }
        }

        std::vector<unsigned char> native(native_bytes);
        if (!in->read_image(0, 0, 0, nch, TypeDesc::UNKNOWN, native.data())) {
            std::string err = oiio_error_text(in->geterror());
            io_image_free(&im);
            return obs_error(ctx, OBS_STATUS_PARSE_ERROR, "cannot read the pixels of '%s': %s", path, err.c_str());
        }
        size_t off = 0;
        for (int c = 0; c < nch; c++) {
            TypeDesc f = spec.channelformat(c);
            bool ok;
            if (im.types[c] == IO_PIXEL_UINT)
                ok = OIIO::convert_image(1, w, h, 1, native.data() + off, f, (OIIO::stride_t)pixel_bytes,
                                         (OIIO::stride_t)(pixel_bytes * (size_t)w), OIIO::AutoStride, im.u32[c].data,
                                         TypeDesc::UINT32, sizeof(uint32_t),
                                         (OIIO::stride_t)(im.u32[c].stride * (ptrdiff_t)sizeof(uint32_t)),
                                         OIIO::AutoStride);
            else
                ok = OIIO::convert_image(1, w, h, 1, native.data() + off, f, (OIIO::stride_t)pixel_bytes,
                                         (OIIO::stride_t)(pixel_bytes * (size_t)w), OIIO::AutoStride, im.f32[c].data,
                                         TypeDesc::FLOAT, sizeof(float),
                                         (OIIO::stride_t)(im.f32[c].stride * (ptrdiff_t)sizeof(float)),
                                         OIIO::AutoStride);
            if (!ok) {
                io_image_free(&im);
                return obs_error(ctx, OBS_STATUS_UNSUPPORTED, "image '%s': cannot convert channel '%s' (%s)", path,
                                 spec.channelnames[c].c_str(), f.c_str());
            }
            off += f.size();
        }
        in->close();

        const auto &extra = spec.extra_attribs;
        if (!extra.empty()) {
            im.attrs = static_cast<io_attr *>(std::calloc(extra.size(), sizeof(io_attr)));
            if (!im.attrs) {
                io_image_free(&im);
                return obs_error(ctx, OBS_STATUS_OUT_OF_MEMORY, "out of memory reading the metadata of '%s'", path);
            }
            for (const auto &p : extra) {
                bool oom = false;
                if (convert_attr(p, &im.attrs[im.attr_count], &oom)) {
                    im.attr_count++;
                } else if (oom) {
                    io_image_free(&im);
                    return obs_error(ctx, OBS_STATUS_OUT_OF_MEMORY, "out of memory reading the metadata of '%s'", path);
                } else {
                    obs_log(ctx, OBS_LOG_DEBUG, "image '%s': attribute '%s' (%s) skipped", path, p.name().c_str(),
                            p.type().c_str());
                }
            }
        }
        *out = im;
        return OBS_STATUS_OK;
    } catch (const std::bad_alloc &) {
        io_image_free(&im);
        return obs_error(ctx, OBS_STATUS_OUT_OF_MEMORY, "out of memory reading '%s'", path);
    } catch (const std::exception &e) {
        io_image_free(&im);
        return obs_error(ctx, OBS_STATUS_PARSE_ERROR, "cannot read image '%s': %s", path, e.what());
    } catch (...) {
        io_image_free(&im);
        return obs_error(ctx, OBS_STATUS_INTERNAL, "cannot read image '%s': unknown exception", path);
    }
}

static obs_status oiio_image_read(obs_context *ctx, const char *path, io_image *out)
{
    if (out)
        std::memset(out, 0, sizeof *out);
    if (!path || !out)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "io_image_read: NULL argument");
    if (FILE *f = std::fopen(path, "rb")) {
        struct stat sb;
        obs_status st = OBS_STATUS_OK;
        if (fstat(fileno(f), &sb) == 0 && S_ISREG(sb.st_mode)) {
            ExrBytes b = {nullptr, f, (uint64_t)sb.st_size};
            st = header_precheck(ctx, path, b);
        }
        std::fclose(f);
        if (st != OBS_STATUS_OK)
            return st;
    }
    return read_image(ctx, path, path, nullptr, out);
}

// OIIO 2.4 reads from memory through an IOProxy (BoundedMemReader: IOMemReader, bounds-checked)
// for the plugins that support
// IOProxy (OpenEXR and PNG among them). OIIO picks the plugin from the name's extension only
// (with a proxy it does not try the others), so EXR and PNG bytes are recognised by their magic
// numbers and opened under a name with the matching extension.
static obs_status oiio_image_read_memory(obs_context *ctx, const char *name, const void *data, size_t len, io_image *out)
{
    if (out)
        std::memset(out, 0, sizeof *out);
    if (!out || (!data && len > 0))
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "io_image_read_memory: NULL argument");
    if (!name || !name[0])
        name = "<memory>";
    if (len == 0)
        return obs_error(ctx, OBS_STATUS_PARSE_ERROR, "cannot read image '%s': no bytes", name);
    ExrBytes eb = {static_cast<const unsigned char *>(data), nullptr, (uint64_t)len};
    obs_status pre = header_precheck(ctx, name, eb);
    if (pre != OBS_STATUS_OK)
        return pre;
    try {
        const unsigned char *b = static_cast<const unsigned char *>(data);
        std::string open_name = name;
        if (len >= 4 && b[0] == 0x76 && b[1] == 0x2f && b[2] == 0x31 && b[3] == 0x01)
            open_name = "memory.exr";
        else if (len >= 8 && std::memcmp(b, "\x89PNG\r\n\x1a\n", 8) == 0)
            open_name = "memory.png";
        BoundedMemReader proxy(data, len);
        return read_image(ctx, name, open_name.c_str(), &proxy, out);
    } catch (const std::bad_alloc &) {
        return obs_error(ctx, OBS_STATUS_OUT_OF_MEMORY, "out of memory reading '%s'", name);
    } catch (...) {
        return obs_error(ctx, OBS_STATUS_INTERNAL, "cannot read image '%s': unknown exception", name);
    }
}

// 8-bit PNG. Values are clamped to [0,1] (NaN -> 0) and quantised by round-to-nearest,
// q = floor(v * 255 + 0.5), after the sRGB encoding for IO_PNG_SRGB (colour planes only: alpha
// is always linear, as PNG defines it). We hand OIIO uint8 data in the file's format, so it
// converts nothing. Tags:
//   IO_PNG_SRGB:   "oiio:ColorSpace" = "sRGB"   -> OIIO writes an sRGB chunk (with gAMA/cHRM).
//   IO_PNG_LINEAR: "oiio:ColorSpace" = "Linear" -> OIIO writes gAMA = 1.0 and no sRGB chunk, so
//                  readers that honour gAMA treat the values as linear (OIIO reads it back as
//                  "Linear"); readers that ignore gAMA will still display them as if sRGB.
// "oiio:UnassociatedAlpha" = 1 stops OIIO from dividing colour by alpha (PNG alpha is
// unassociated): the RGBA planes are written exactly as given.
static obs_status oiio_png_write(obs_context *ctx, const char *path, const obs_image_f32 *planes, int plane_count,
                        io_png_encoding encoding)
{
    try {
        if (!path || !path[0] || !planes)
            return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "io_png_write: NULL or empty argument");
        if (plane_count != 1 && plane_count != 3 && plane_count != 4)
            return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "cannot write '%s': %d planes (1, 3 or 4 expected)", path,
                             plane_count);
        if (encoding != IO_PNG_SRGB && encoding != IO_PNG_LINEAR)
            return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "cannot write '%s': invalid encoding %d", path,
                             (int)encoding);
        const int w = planes[0].width, h = planes[0].height;
        for (int c = 0; c < plane_count; c++) {
            if (!planes[c].data || planes[c].width < 1 || planes[c].height < 1 || planes[c].stride < planes[c].width)
                return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "cannot write '%s': plane %d is empty or has a bad stride",
                                 path, c);
            if (planes[c].width != w || planes[c].height != h)
                return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "cannot write '%s': plane %d is %dx%d, plane 0 is %dx%d",
                                 path, c, planes[c].width, planes[c].height, w, h);
        }
        size_t total;
        if (!obs_mul_size((size_t)w, (size_t)h, &total) || !obs_mul_size(total, (size_t)plane_count, &total))
            return obs_error(ctx, OBS_STATUS_LIMIT_EXCEEDED, "cannot write '%s': size overflows", path);
        std::vector<unsigned char> buf(total);
        const int alpha = plane_count == 4 ? 3 : -1;
        for (int c = 0; c < plane_count; c++) {
            bool encode = encoding == IO_PNG_SRGB && c != alpha;
            for (int y = 0; y < h; y++) {
                const float *src = obs_image_f32_row(&planes[c], y);
                unsigned char *dst = buf.data() + (size_t)y * w * plane_count + c;
                for (int x = 0; x < w; x++) {
                    float v = src[x];
                    if (!(v > 0.0f))
                        v = 0.0f; // NaN and negatives
                    else if (v > 1.0f)
                        v = 1.0f;
                    if (encode)
                        v = io_srgb_encode(v);
                    dst[(size_t)x * plane_count] = (unsigned char)std::floor((double)v * 255.0 + 0.5);
                }
            }
        }
        ImageSpec spec(w, h, plane_count, TypeDesc::UINT8);
        spec.channelnames.clear();
        static const char *const grey[] = {"Y"};
        static const char *const rgba[] = {"R", "G", "B", "A"};
        for (int c = 0; c < plane_count; c++)
            spec.channelnames.emplace_back(plane_count == 1 ? grey[c] : rgba[c]);
        spec.alpha_channel = alpha;
        spec.attribute("oiio:ColorSpace", encoding == IO_PNG_SRGB ? "sRGB" : "Linear");
        spec.attribute("oiio:UnassociatedAlpha", 1);

        std::string tmp;
        obs_status st = make_temp(ctx, path, tmp);
        if (st != OBS_STATUS_OK)
            return st;
        return write_with_oiio(ctx, "png", path, tmp, spec, TypeDesc::UINT8, buf.data());
    } catch (const std::bad_alloc &) {
        return obs_error(ctx, OBS_STATUS_OUT_OF_MEMORY, "out of memory writing '%s'", path ? path : "(null)");
    } catch (const std::exception &e) {
        return obs_error(ctx, OBS_STATUS_IO_ERROR, "cannot write '%s': %s", path ? path : "(null)", e.what());
    } catch (...) {
        return obs_error(ctx, OBS_STATUS_INTERNAL, "cannot write '%s': unknown exception", path ? path : "(null)");
    }
}


// The module's one exported symbol (IO_IMAGE_MODULE_ENTRY): keeps the host's table and returns
// ours. Called once, under the host's pthread_once, before any other call into the module.
extern "C" __attribute__((visibility("default"))) const io_image_module *obs_io_image_module_v1(const io_image_host *host)
{
    static const io_image_module mod = {IO_IMAGE_MODULE_ABI, oiio_exr_write, oiio_png_write, oiio_image_read,
                                        oiio_image_read_memory};
    if (!host || host->abi != IO_IMAGE_MODULE_ABI)
        return nullptr;
    g_host = host;
    return &mod;
}
