/* io_gltf.cpp: glTF 2.0 loader (.gltf with external or data-URI buffers, and .glb), a thin C++17
 * adapter over tinygltf 2.7 behind the C API of io.h.
 *
 * tinygltf parses the JSON and loads buffers, but it checks neither accessor nor bufferView
 * ranges (build-notes.md), and its GLB reader trusts the BIN chunk length by 8 bytes too many.
 * So this file
 *   - reads the file itself, checks the GLB container strictly and the JSON nesting depth
 *     (tinygltf converts "extras" recursively) before handing the bytes to tinygltf;
 *   - reads the JSON once itself (Preflight, nlohmann::json) to refuse other glTF versions and
 *     unsupported required extensions by name, and to decode EXT_meshopt_compression
 *     (libmeshoptimizer) and KHR_draco_mesh_compression (libdraco) into plain buffers, sizes
 *     checked before allocation, so tinygltf and the checks below see ordinary glTF 2.0;
 *   - reads KHR_mesh_quantization's integer and normalized attributes (docs/gltf.md);
 *   - gives tinygltf file-system callbacks that accept regular files only, resolve external
 *     buffers next to the .gltf only (not in the current directory), and cap their size;
 *   - gives tinygltf an image loader that decodes nothing (we need no textures);
 *   - checks every index, accessor, bufferView and buffer range with overflow-safe 64-bit
 *     arithmetic before reading a byte, and checks counts against the context's limits before
 *     allocating;
 *   - checks the node graph (child ranges, single parent, no cycles) iteratively before walking.
 * io_gltf_load_memory takes the same path from the bytes on: only Loader::read_file differs (it
 * copies the caller's bytes), and the file-system callbacks then resolve no external file.
 * Every error message starts with the file path and names the offending glTF object.
 * No C++ exception leaves this file. */
#include "io.h"

#include <tiny_gltf.h>

#include <draco/compression/decode.h>
#include <meshoptimizer.h>
#include <nlohmann/json.hpp>

#include <cerrno>
#include <cmath>
#include <cstdarg>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <memory>
#include <new>
#include <string>
#include <vector>

#include <sys/stat.h>

namespace {

constexpr int kMaxJsonDepth = 512;

/* ---- small helpers ------------------------------------------------------------------------ */

void copy_name(char dst[OBS_NAME_MAX], const std::string &src)
{
    size_t n = src.size();
    if (n > OBS_NAME_MAX - 1) {
        n = OBS_NAME_MAX - 1;
        /* do not cut a UTF-8 sequence in half: back off over continuation bytes */
        while (n > 0 && (static_cast<unsigned char>(src[n]) & 0xC0) == 0x80)
            n--;
    }
    memcpy(dst, src.data(), n);
    dst[n] = '\0';
}

bool add_u64(uint64_t a, uint64_t b, uint64_t *out) { return !__builtin_add_overflow(a, b, out); }
bool mul_u64(uint64_t a, uint64_t b, uint64_t *out) { return !__builtin_mul_overflow(a, b, out); }

/* " 'name'" for a named object, "" otherwise (for messages) */
std::string quoted(const std::string &name) { return name.empty() ? std::string() : " '" + name + "'"; }

std::string lower_ext(const char *path)
{
    const char *slash = strrchr(path, '/');
    const char *dot = strrchr(path, '.');
    if (!dot || (slash && dot < slash))
        return std::string();
    std::string e(dot + 1);
    for (char &c : e)
        if (c >= 'A' && c <= 'Z')
            c = static_cast<char>(c - 'A' + 'a');
    return e;
}

std::string base_dir(const char *path)
{
    const char *slash = strrchr(path, '/');
    if (!slash)
        return std::string();
    if (slash == path)
        return std::string("/");
    return std::string(path, static_cast<size_t>(slash - path));
}

/* tinygltf's messages end in newlines and may hold several lines: make them one line. */
std::string one_line(const std::string &s, size_t max_len = 400)
{
    std::string r;
    for (char c : s) {
        if (c == '\n' || c == '\r') {
            if (!r.empty() && r.back() != ' ')
                r += "; ";
        } else {
            r += c;
        }
    }
    while (!r.empty() && (r.back() == ' ' || r.back() == ';'))
        r.pop_back();
    if (r.size() > max_len) {
        r.resize(max_len);
        r += "...";
    }
    return r;
}

uint32_t rd_le32(const unsigned char *p)
{
    return static_cast<uint32_t>(p[0]) | (static_cast<uint32_t>(p[1]) << 8) | (static_cast<uint32_t>(p[2]) << 16) |
           (static_cast<uint32_t>(p[3]) << 24);
}

/* Deepest nesting of [ and { outside strings. Returns -1 on a nesting deeper than limit. */
int json_depth_ok(const unsigned char *s, size_t n, int limit)
{
    int depth = 0;
    bool in_str = false, esc = false;
    for (size_t i = 0; i < n; i++) {
        unsigned char c = s[i];
        if (in_str) {
            if (esc)
                esc = false;
            else if (c == '\\')
                esc = true;
            else if (c == '"')
                in_str = false;
        } else if (c == '"') {
            in_str = true;
        } else if (c == '[' || c == '{') {
            if (++depth > limit)
                return 0;
        } else if (c == ']' || c == '}') {
            depth--;
        }
    }
    return 1;
}

/* ---- tinygltf::Value -> compact JSON --------------------------------------------------------- */

void json_escape(std::string &out, const std::string &s)
{
    out += '"';
    for (unsigned char c : s) {
        switch (c) {
        case '"': out += "\\\""; break;
        case '\\': out += "\\\\"; break;
        case '\b': out += "\\b"; break;
        case '\f': out += "\\f"; break;
        case '\n': out += "\\n"; break;
        case '\r': out += "\\r"; break;
        case '\t': out += "\\t"; break;
        default:
            if (c < 0x20 || c == 0x7F) {
                char buf[8];
                snprintf(buf, sizeof buf, "\\u%04x", c);
                out += buf;
            } else {
                out += static_cast<char>(c);
            }
        }
    }
    out += '"';
}

void json_number(std::string &out, double d)
{
    if (!std::isfinite(d)) {
        out += "null";
        return;
    }
    char buf[40];
    /* the shortest of %.15g..%.17g that reads back exactly */
    for (int prec = 15; prec <= 17; prec++) {
        snprintf(buf, sizeof buf, "%.*g", prec, d);
        if (strtod(buf, nullptr) == d)
            break;
    }
    out += buf;
}

bool value_to_json(std::string &out, const tinygltf::Value &v, int depth)
{
    if (depth > kMaxJsonDepth)
        return false;
    switch (v.Type()) {
    case tinygltf::NULL_TYPE: out += "null"; return true;
    case tinygltf::BOOL_TYPE: out += v.Get<bool>() ? "true" : "false"; return true;
    case tinygltf::INT_TYPE: out += std::to_string(v.Get<int>()); return true;
    case tinygltf::REAL_TYPE: json_number(out, v.Get<double>()); return true;
    case tinygltf::STRING_TYPE: json_escape(out, v.Get<std::string>()); return true;
    case tinygltf::BINARY_TYPE: out += "null"; return true;
    case tinygltf::ARRAY_TYPE: {
        out += '[';
        bool first = true;
        for (const tinygltf::Value &e : v.Get<tinygltf::Value::Array>()) {
            if (!first)
                out += ',';
            first = false;
            if (!value_to_json(out, e, depth + 1))
                return false;
        }
        out += ']';
        return true;
    }
    case tinygltf::OBJECT_TYPE: {
        out += '{';
        bool first = true;
        for (const auto &kv : v.Get<tinygltf::Value::Object>()) {
            if (!first)
                out += ',';
            first = false;
            json_escape(out, kv.first);
            out += ':';
            if (!value_to_json(out, kv.second, depth + 1))
                return false;
        }
        out += '}';
        return true;
    }
    default: out += "null"; return true;
    }
}

/* ---- file-system callbacks for tinygltf ------------------------------------------------------ */

struct FsState {
    std::string base;        /* directory of the .gltf ("" = current directory) */
    uint64_t max_bytes;      /* cap on one external file */
    std::string failure;     /* first external-file failure, for the message */
    bool memory = false;     /* loading from memory: no external file resolves */
};

bool fs_file_exists(const std::string &p, void *user)
{
    FsState *st = static_cast<FsState *>(user);
    if (st->memory)
        return false;
    /* tinygltf tries <base>/<uri> and then ./<uri>; only accept the first when there is a base */
    if (!st->base.empty() && p.compare(0, st->base.size(), st->base) != 0)
        return false;
    struct stat sb;
    return stat(p.c_str(), &sb) == 0 && S_ISREG(sb.st_mode);
}

std::string fs_expand(const std::string &p, void *) { return p; }

bool fs_read(std::vector<unsigned char> *out, std::string *err, const std::string &p, void *user)
{
    FsState *st = static_cast<FsState *>(user);
    if (st->memory) {
        if (err)
            *err += "external files cannot be read when loading from memory";
        return false;
    }
    FILE *f = fopen(p.c_str(), "rb");
    if (!f) {
        if (err)
            *err += strerror(errno);
        if (st->failure.empty())
            st->failure = p + ": " + strerror(errno);
        return false;
    }
    struct stat sb;
    if (fstat(fileno(f), &sb) != 0 || !S_ISREG(sb.st_mode)) {
        fclose(f);
        if (err)
            *err += "not a regular file";
        return false;
    }
    if (static_cast<uint64_t>(sb.st_size) > st->max_bytes) {
        fclose(f);
        if (err)
            *err += "file too large (" + std::to_string(static_cast<long long>(sb.st_size)) + " bytes)";
        return false;
    }
    out->resize(static_cast<size_t>(sb.st_size));
    size_t got = out->empty() ? 0 : fread(out->data(), 1, out->size(), f);
    int bad = ferror(f);
    fclose(f);
    if (bad || got != out->size()) {
        if (err)
            *err += "short read";
        return false;
    }
    return true;
}

bool fs_write(std::string *err, const std::string &, const std::vector<unsigned char> &, void *)
{
    if (err)
        *err += "writing is disabled";
    return false;
}

bool no_image_decode(tinygltf::Image *, const int, std::string *, std::string *, int, int, const unsigned char *, int,
                     void *)
{
    return true; /* textures are not used by obscura: keep the bytes undecoded */
}

const char *component_name(int ct);

/* "<path>: <message>" into the context's error; the loaders' fail() */
obs_status fail_v(obs_context *ctx, const char *path, obs_status st, const char *fmt, va_list ap)
{
    char msg[900];
    vsnprintf(msg, sizeof msg, fmt, ap);
    return obs_error(ctx, st, "%s: %s", path, msg);
}

/* ---- before tinygltf: version, required extensions, Draco and meshopt --------------------------
 *
 * The JSON is read once here with nlohmann::json (the parser tinygltf itself uses), so that
 *   - an unsupported asset.version / asset.minVersion and an unsupported required extension are
 *     refused in our words, naming the version or the extension, before tinygltf's own checks;
 *   - EXT_meshopt_compression bufferViews and KHR_draco_mesh_compression primitives are decoded
 *     into plain buffers (data: URIs) and the document is rewritten without the extension, so
 *     that everything tinygltf and our range checks see afterwards is ordinary glTF 2.0.
 * Every size a decoder will write (count * byteStride, Draco's point and face counts) is checked
 * against the declared bufferView or accessor and against the context's limits before the
 * buffer is allocated. */

using Json = nlohmann::json;

/* extensions obscura reads, or may ignore because they change only what obscura does not read */
bool extension_supported(const std::string &e)
{
    static const char *const exact[] = {"KHR_lights_punctual", "KHR_mesh_quantization", "KHR_draco_mesh_compression",
                                        "EXT_meshopt_compression"};
    static const char *const harmless_prefixes[] = {"KHR_materials_", "KHR_texture_", "EXT_texture_"};
    for (const char *x : exact)
        if (e == x)
            return true;
    for (const char *pre : harmless_prefixes)
        if (e.compare(0, strlen(pre), pre) == 0)
            return true;
    return false;
}

/* "MAJOR.MINOR" (glTF 2.0 spec 5.2, asset.version pattern ^[0-9]+\.[0-9]+$) */
bool parse_version(const std::string &s, long *major, long *minor)
{
    const char *p = s.c_str();
    char *end;
    if (!(*p >= '0' && *p <= '9'))
        return false;
    errno = 0;
    *major = strtol(p, &end, 10);
    if (*end != '.' || !(end[1] >= '0' && end[1] <= '9') || errno)
        return false;
    *minor = strtol(end + 1, &end, 10);
    return *end == '\0' && !errno;
}

/* a non-negative integer member (absent: def); false when present but not such an integer */
bool json_uint(const Json &obj, const char *key, uint64_t def, uint64_t *out)
{
    auto it = obj.find(key);
    if (it == obj.end()) {
        *out = def;
        return true;
    }
    if (it->is_number_unsigned()) {
        *out = it->get<uint64_t>();
        return true;
    }
    if (it->is_number_integer() && it->get<int64_t>() >= 0) {
        *out = static_cast<uint64_t>(it->get<int64_t>());
        return true;
    }
    return false;
}

const char kB64[] = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";

std::string base64_data_uri(const std::vector<unsigned char> &d)
{
    std::string s = "data:application/octet-stream;base64,";
    s.reserve(s.size() + (d.size() + 2) / 3 * 4);
    size_t i = 0;
    for (; i + 2 < d.size(); i += 3) {
        uint32_t v = (uint32_t(d[i]) << 16) | (uint32_t(d[i + 1]) << 8) | d[i + 2];
        s += kB64[v >> 18];
        s += kB64[(v >> 12) & 63];
        s += kB64[(v >> 6) & 63];
        s += kB64[v & 63];
    }
    if (i < d.size()) {
        uint32_t v = uint32_t(d[i]) << 16;
        if (i + 1 < d.size())
            v |= uint32_t(d[i + 1]) << 8;
        s += kB64[v >> 18];
        s += kB64[(v >> 12) & 63];
        s += i + 1 < d.size() ? kB64[(v >> 6) & 63] : '=';
        s += '=';
    }
    return s;
}

/* decode the base64 part of a data: URI (RFC 4648 alphabet, '=' padding optional) */
bool base64_decode(const std::string &s, size_t from, std::vector<unsigned char> *out)
{
    uint32_t acc = 0;
    int bits = 0;
    for (size_t i = from; i < s.size(); i++) {
        char c = s[i];
        int v;
        if (c >= 'A' && c <= 'Z') v = c - 'A';
        else if (c >= 'a' && c <= 'z') v = c - 'a' + 26;
        else if (c >= '0' && c <= '9') v = c - '0' + 52;
        else if (c == '+') v = 62;
        else if (c == '/') v = 63;
        else if (c == '=') break;
        else return false;
        acc = (acc << 6) | static_cast<uint32_t>(v);
        bits += 6;
        if (bits >= 8) {
            bits -= 8;
            out->push_back(static_cast<unsigned char>(acc >> bits));
        }
    }
    return true;
}

class Preflight {
public:
    Preflight(obs_context *ctx, const char *path, const obs_limits &lim, FsState &fs, std::vector<unsigned char> &bytes,
              bool binary)
        : ctx_(ctx), path_(path), lim_(lim), fs_(fs), bytes_(bytes), binary_(binary)
    {
    }
    /* *len: the GLB length (binary) in and out */
    obs_status run(uint32_t *glb_len);

private:
    obs_status fail(obs_status st, const char *fmt, ...) __attribute__((format(printf, 3, 4)));
    obs_status check_asset();
    obs_status check_required();
    obs_status buffer_data(uint64_t index, const std::vector<unsigned char> **out);
    obs_status slice(uint64_t buffer, uint64_t offset, uint64_t length, const std::string &what,
                     const unsigned char **out);
    obs_status reserve(uint64_t bytes, const std::string &what);
    obs_status meshopt();
    obs_status draco();
    obs_status draco_primitive(size_t mi, size_t pi, Json &prim, std::vector<unsigned char> &out,
                               std::vector<bool> &decoded);
    obs_status rebuild(uint32_t *glb_len);

    obs_context *ctx_;
    const char *path_;
    obs_limits lim_;
    FsState &fs_;
    std::vector<unsigned char> &bytes_;
    bool binary_;
    Json doc_;
    const unsigned char *bin_ = nullptr; /* the GLB BIN chunk */
    uint64_t bin_len_ = 0;
    std::vector<std::vector<unsigned char>> loaded_; /* buffers read for decoding */
    std::vector<bool> have_loaded_;
    uint64_t decoded_bytes_ = 0;
};

obs_status Preflight::fail(obs_status st, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    obs_status r = fail_v(ctx_, path_, st, fmt, ap);
    va_end(ap);
    return r;
}

/* glTF 2.0 spec 5.2 (asset): version is required; minVersion is the least version a loader must
 * support. obscura reads 2.x (a 2.x file without a minVersion above 2.0 loads in a 2.0 loader). */
obs_status Preflight::check_asset()
{
    auto asset = doc_.find("asset");
    if (asset == doc_.end() || !asset->is_object())
        return fail(OBS_STATUS_PARSE_ERROR, "no 'asset' object (glTF 2.0 requires asset.version)");
    auto ver = asset->find("version");
    if (ver == asset->end() || !ver->is_string())
        return fail(OBS_STATUS_PARSE_ERROR, "asset.version is missing or not a string (glTF 2.0 requires it)");
    const std::string v = ver->get<std::string>();
    long major = 0, minor = 0;
    if (!parse_version(v, &major, &minor))
        return fail(OBS_STATUS_PARSE_ERROR, "asset.version '%s' is not of the form MAJOR.MINOR", one_line(v, 40).c_str());
    if (major != 2)
        return fail(OBS_STATUS_UNSUPPORTED,
                    "glTF version %s is not supported: obscura reads glTF 2.x (convert a 1.0 file to 2.0 first, e.g. "
                    "with Blender or the Khronos glTF 1.0-to-2.0 converter)",
                    one_line(v, 40).c_str());
    auto minv = asset->find("minVersion");
    if (minv != asset->end()) {
        if (!minv->is_string())
            return fail(OBS_STATUS_PARSE_ERROR, "asset.minVersion is not a string");
        const std::string m = minv->get<std::string>();
        long mmaj = 0, mmin = 0;
        if (!parse_version(m, &mmaj, &mmin))
            return fail(OBS_STATUS_PARSE_ERROR, "asset.minVersion '%s' is not of the form MAJOR.MINOR",
                        one_line(m, 40).c_str());
        if (mmaj != 2 || mmin > 0)
            return fail(OBS_STATUS_UNSUPPORTED,
                        "asset.minVersion %s: the file needs a glTF %s loader; obscura reads glTF 2.0",
                        one_line(m, 40).c_str(), one_line(m, 40).c_str());
    }
    return OBS_STATUS_OK;
}

/* glTF 2.0 spec 3.12: a loader MUST refuse a file whose extensionsRequired it does not support. */
obs_status Preflight::check_required()
{
    auto req = doc_.find("extensionsRequired");
    if (req == doc_.end())
        return OBS_STATUS_OK;
    if (!req->is_array())
        return fail(OBS_STATUS_PARSE_ERROR, "extensionsRequired is not an array");
    for (const Json &e : *req) {
        if (!e.is_string())
            return fail(OBS_STATUS_PARSE_ERROR, "extensionsRequired holds a non-string");
        const std::string name = e.get<std::string>();
        if (!extension_supported(name))
            return fail(OBS_STATUS_UNSUPPORTED,
                        "requires the extension %s, which obscura does not support (supported: KHR_mesh_quantization, "
                        "KHR_draco_mesh_compression, EXT_meshopt_compression, KHR_lights_punctual; KHR_materials_*, "
                        "KHR_texture_* and EXT_texture_* are ignored)",
                        one_line(name, 80).c_str());
    }
    return OBS_STATUS_OK;
}

/* count bytes more of decoded data, within --max-memory */
obs_status Preflight::reserve(uint64_t bytes, const std::string &what)
{
    uint64_t total;
    if (!add_u64(decoded_bytes_, bytes, &total) || total > static_cast<uint64_t>(lim_.max_memory_bytes) ||
        total > 0xFFFFFFFFull)
        return fail(OBS_STATUS_LIMIT_EXCEEDED, "%s: %llu bytes of decoded data (%llu so far) over the limit of %lld "
                                               "(--max-memory; at most 4 GiB per file)",
                    what.c_str(), static_cast<unsigned long long>(bytes),
                    static_cast<unsigned long long>(decoded_bytes_), static_cast<long long>(lim_.max_memory_bytes));
    decoded_bytes_ = total;
    return OBS_STATUS_OK;
}

/* the bytes of buffer `index` as the file stores them: the GLB BIN chunk, a data: URI or a file
 * beside the .gltf (through the same file-system rules as tinygltf's callbacks) */
obs_status Preflight::buffer_data(uint64_t index, const std::vector<unsigned char> **out)
{
    auto bufs = doc_.find("buffers");
    if (bufs == doc_.end() || !bufs->is_array() || index >= bufs->size())
        return fail(OBS_STATUS_PARSE_ERROR, "buffer %llu out of range (%zu buffers)",
                    static_cast<unsigned long long>(index), bufs != doc_.end() && bufs->is_array() ? bufs->size() : 0);
    if (loaded_.size() != bufs->size()) {
        loaded_.assign(bufs->size(), std::vector<unsigned char>());
        have_loaded_.assign(bufs->size(), false);
    }
    std::vector<unsigned char> &d = loaded_[static_cast<size_t>(index)];
    if (have_loaded_[static_cast<size_t>(index)]) {
        *out = &d;
        return OBS_STATUS_OK;
    }
    const Json &b = (*bufs)[static_cast<size_t>(index)];
    uint64_t byte_length;
    if (!b.is_object() || !json_uint(b, "byteLength", UINT64_MAX, &byte_length) || byte_length == UINT64_MAX)
        return fail(OBS_STATUS_PARSE_ERROR, "buffer %llu: no valid byteLength", static_cast<unsigned long long>(index));
    auto uri = b.find("uri");
    if (uri == b.end()) {
        if (!(binary_ && index == 0 && bin_))
            return fail(OBS_STATUS_PARSE_ERROR, "buffer %llu has no uri and is not the GLB BIN chunk",
                        static_cast<unsigned long long>(index));
        if (byte_length > bin_len_)
            return fail(OBS_STATUS_PARSE_ERROR, "buffer 0: byteLength %llu > GLB BIN chunk length %llu",
                        static_cast<unsigned long long>(byte_length), static_cast<unsigned long long>(bin_len_));
        d.assign(bin_, bin_ + byte_length);
    } else {
        if (!uri->is_string())
            return fail(OBS_STATUS_PARSE_ERROR, "buffer %llu: uri is not a string", static_cast<unsigned long long>(index));
        const std::string u = uri->get<std::string>();
        if (u.compare(0, 5, "data:") == 0) {
            size_t comma = u.find(";base64,");
            if (comma == std::string::npos || !base64_decode(u, comma + 8, &d))
                return fail(OBS_STATUS_PARSE_ERROR, "buffer %llu: malformed data: URI (base64 expected)",
                            static_cast<unsigned long long>(index));
        } else {
            const std::string p = fs_.base.empty() ? u : fs_.base + "/" + u;
            std::string err;
            if (fs_.memory)
                return fail(OBS_STATUS_IO_ERROR, "buffer %llu ('%s'): an external buffer cannot be resolved when "
                                                 "loading from memory",
                            static_cast<unsigned long long>(index), one_line(u, 200).c_str());
            if (!fs_file_exists(p, &fs_) || !fs_read(&d, &err, p, &fs_))
                return fail(OBS_STATUS_IO_ERROR, "buffer %llu: cannot read '%s'%s%s", static_cast<unsigned long long>(index),
                            one_line(p, 300).c_str(), err.empty() ? "" : ": ", one_line(err).c_str());
        }
        if (d.size() < byte_length)
            return fail(OBS_STATUS_PARSE_ERROR, "buffer %llu: %zu bytes, fewer than its byteLength %llu",
                        static_cast<unsigned long long>(index), d.size(), static_cast<unsigned long long>(byte_length));
    }
    have_loaded_[static_cast<size_t>(index)] = true;
    *out = &d;
    return OBS_STATUS_OK;
}

obs_status Preflight::slice(uint64_t buffer, uint64_t offset, uint64_t length, const std::string &what,
                            const unsigned char **out)
{
    const std::vector<unsigned char> *d;
    obs_status st = buffer_data(buffer, &d);
    if (st != OBS_STATUS_OK)
        return st;
    uint64_t end;
    if (!add_u64(offset, length, &end) || end > d->size())
        return fail(OBS_STATUS_PARSE_ERROR, "%s: byteOffset %llu + byteLength %llu > buffer %llu size %zu", what.c_str(),
                    static_cast<unsigned long long>(offset), static_cast<unsigned long long>(length),
                    static_cast<unsigned long long>(buffer), d->size());
    *out = d->data() + offset;
    return OBS_STATUS_OK;
}

/* EXT_meshopt_compression (Khronos extension spec, "Specifying compressed views" and "Filters"):
 * each compressed bufferView is decoded into its fallback buffer at its own byteOffset; the
 * fallback buffers then carry the decoded bytes as data: URIs. */
obs_status Preflight::meshopt()
{
    auto views = doc_.find("bufferViews");
    if (views == doc_.end() || !views->is_array())
        return OBS_STATUS_OK;
    auto bufs = doc_.find("buffers");
    const size_t nbuf = bufs != doc_.end() && bufs->is_array() ? bufs->size() : 0;
    std::vector<std::vector<unsigned char>> target(nbuf);
    std::vector<bool> is_target(nbuf, false), is_source(nbuf, false);
    for (size_t vi = 0; vi < views->size(); vi++) {
        Json &bv = (*views)[vi];
        if (!bv.is_object())
            continue;
        auto exts = bv.find("extensions");
        if (exts == bv.end() || !exts->is_object())
            continue;
        auto mo = exts->find("EXT_meshopt_compression");
        if (mo == exts->end())
            continue;
        const std::string what = "bufferView " + std::to_string(vi) + " (EXT_meshopt_compression)";
        if (!mo->is_object())
            return fail(OBS_STATUS_PARSE_ERROR, "%s: not an object", what.c_str());
        uint64_t src, off, len, stride, count, tgt, toff, tlen;
        if (!json_uint(*mo, "buffer", UINT64_MAX, &src) || !json_uint(*mo, "byteOffset", 0, &off) ||
            !json_uint(*mo, "byteLength", UINT64_MAX, &len) || !json_uint(*mo, "byteStride", UINT64_MAX, &stride) ||
            !json_uint(*mo, "count", UINT64_MAX, &count) || src == UINT64_MAX || len == UINT64_MAX ||
            stride == UINT64_MAX || count == UINT64_MAX)
            return fail(OBS_STATUS_PARSE_ERROR, "%s: buffer, byteLength, byteStride and count must be integers >= 0",
                        what.c_str());
        if (!json_uint(bv, "buffer", UINT64_MAX, &tgt) || !json_uint(bv, "byteOffset", 0, &toff) ||
            !json_uint(bv, "byteLength", UINT64_MAX, &tlen) || tgt == UINT64_MAX || tlen == UINT64_MAX)
            return fail(OBS_STATUS_PARSE_ERROR, "%s: the bufferView's buffer and byteLength must be integers >= 0",
                        what.c_str());
        const std::string mode = mo->contains("mode") && (*mo)["mode"].is_string() ? (*mo)["mode"].get<std::string>() : "";
        const std::string filter =
            mo->contains("filter") && (*mo)["filter"].is_string() ? (*mo)["filter"].get<std::string>() : "NONE";
        /* the decoders' preconditions (meshoptimizer.h), checked here rather than asserted there */
        if (mode == "ATTRIBUTES") {
            if (stride == 0 || stride > 256 || stride % 4 != 0)
                return fail(OBS_STATUS_PARSE_ERROR, "%s: ATTRIBUTES byteStride %llu is not a multiple of 4 in [4, 256]",
                            what.c_str(), static_cast<unsigned long long>(stride));
            if (!(filter == "NONE" || (filter == "OCTAHEDRAL" && (stride == 4 || stride == 8)) ||
                  (filter == "QUATERNION" && stride == 8) || filter == "EXPONENTIAL"))
                return fail(OBS_STATUS_PARSE_ERROR, "%s: filter %s with byteStride %llu is not valid", what.c_str(),
                            one_line(filter, 40).c_str(), static_cast<unsigned long long>(stride));
        } else if (mode == "TRIANGLES" || mode == "INDICES") {
            if (stride != 2 && stride != 4)
                return fail(OBS_STATUS_PARSE_ERROR, "%s: %s byteStride %llu is neither 2 nor 4", what.c_str(),
                            mode.c_str(), static_cast<unsigned long long>(stride));
            if (mode == "TRIANGLES" && count % 3 != 0)
                return fail(OBS_STATUS_PARSE_ERROR, "%s: TRIANGLES count %llu is not a multiple of 3", what.c_str(),
                            static_cast<unsigned long long>(count));
            if (filter != "NONE")
                return fail(OBS_STATUS_PARSE_ERROR, "%s: filter %s on %s data", what.c_str(),
                            one_line(filter, 40).c_str(), mode.c_str());
        } else {
            return fail(OBS_STATUS_UNSUPPORTED, "%s: mode '%s' is not ATTRIBUTES, TRIANGLES or INDICES", what.c_str(),
                        one_line(mode, 40).c_str());
        }
        /* sizes before allocation: the decoded view must fit the declared view, the view its buffer */
        uint64_t size, tend;
        if (!mul_u64(count, stride, &size) || size > tlen)
            return fail(OBS_STATUS_PARSE_ERROR, "%s: count %llu * byteStride %llu > the bufferView's byteLength %llu",
                        what.c_str(), static_cast<unsigned long long>(count), static_cast<unsigned long long>(stride),
                        static_cast<unsigned long long>(tlen));
        if (tgt >= nbuf)
            return fail(OBS_STATUS_PARSE_ERROR, "%s: buffer %llu out of range (%zu buffers)", what.c_str(),
                        static_cast<unsigned long long>(tgt), nbuf);
        uint64_t tbuf_len;
        if (!json_uint((*bufs)[static_cast<size_t>(tgt)], "byteLength", UINT64_MAX, &tbuf_len) ||
            tbuf_len == UINT64_MAX || !add_u64(toff, tlen, &tend) || tend > tbuf_len)
            return fail(OBS_STATUS_PARSE_ERROR, "%s: byteOffset %llu + byteLength %llu is not inside buffer %llu",
                        what.c_str(), static_cast<unsigned long long>(toff), static_cast<unsigned long long>(tlen),
                        static_cast<unsigned long long>(tgt));
        if (src == tgt)
            return fail(OBS_STATUS_PARSE_ERROR, "%s: buffer %llu is both the compressed source and the target",
                        what.c_str(), static_cast<unsigned long long>(src));
        const unsigned char *data = nullptr;
        obs_status st = slice(src, off, len, what, &data);
        if (st != OBS_STATUS_OK)
            return st;
        is_source[static_cast<size_t>(src < nbuf ? src : 0)] = true;
        std::vector<unsigned char> &t = target[static_cast<size_t>(tgt)];
        if (!is_target[static_cast<size_t>(tgt)]) {
            if ((st = reserve(tbuf_len, "buffer " + std::to_string(tgt))) != OBS_STATUS_OK)
                return st;
            t.assign(static_cast<size_t>(tbuf_len), 0);
            is_target[static_cast<size_t>(tgt)] = true;
        }
        unsigned char *dst = t.data() + toff;
        int rc;
        if (mode == "ATTRIBUTES")
            rc = meshopt_decodeVertexBuffer(dst, static_cast<size_t>(count), static_cast<size_t>(stride), data,
                                            static_cast<size_t>(len));
        else if (mode == "TRIANGLES")
            rc = meshopt_decodeIndexBuffer(dst, static_cast<size_t>(count), static_cast<size_t>(stride), data,
                                           static_cast<size_t>(len));
        else
            rc = meshopt_decodeIndexSequence(dst, static_cast<size_t>(count), static_cast<size_t>(stride), data,
                                             static_cast<size_t>(len));
        if (rc != 0)
            return fail(OBS_STATUS_PARSE_ERROR,
                        "%s: the %s data does not decode (meshoptimizer %d.%d error %d: corrupt data or a codec "
                        "version newer than this meshoptimizer)",
                        what.c_str(), mode.c_str(), MESHOPTIMIZER_VERSION / 100, MESHOPTIMIZER_VERSION % 100, rc);
        if (filter == "OCTAHEDRAL")
            meshopt_decodeFilterOct(dst, static_cast<size_t>(count), static_cast<size_t>(stride));
        else if (filter == "QUATERNION")
            meshopt_decodeFilterQuat(dst, static_cast<size_t>(count), static_cast<size_t>(stride));
        else if (filter == "EXPONENTIAL")
            meshopt_decodeFilterExp(dst, static_cast<size_t>(count), static_cast<size_t>(stride));
        exts->erase("EXT_meshopt_compression");
        if (exts->empty())
            bv.erase("extensions");
    }
    for (size_t b = 0; b < nbuf; b++) {
        if (!is_target[b])
            continue;
        if (is_source[b])
            return fail(OBS_STATUS_PARSE_ERROR, "buffer %zu is both a source and a target of EXT_meshopt_compression", b);
        Json &buf = (*bufs)[b];
        buf["uri"] = base64_data_uri(target[b]);
        std::vector<unsigned char>().swap(target[b]);
        auto exts = buf.find("extensions");
        if (exts != buf.end() && exts->is_object()) {
            exts->erase("EXT_meshopt_compression");
            if (exts->empty())
                buf.erase("extensions");
        }
    }
    return OBS_STATUS_OK;
}

/* KHR_draco_mesh_compression (Khronos extension spec): the primitive's bufferView holds a Draco
 * mesh; its attributes map glTF attribute names to Draco unique ids, and the primitive's
 * accessors give the decoded types and counts. POSITION and NORMAL (FLOAT VEC3) and the indices
 * are decoded; other attributes are not read by obscura and stay without a bufferView. */
obs_status Preflight::draco_primitive(size_t mi, size_t pi, Json &prim, std::vector<unsigned char> &out,
                                      std::vector<bool> &decoded)
{
    const std::string what =
        "mesh " + std::to_string(mi) + " primitive " + std::to_string(pi) + " (KHR_draco_mesh_compression)";
    Json &ext = prim["extensions"]["KHR_draco_mesh_compression"];
    uint64_t bvi;
    if (!ext.is_object() || !json_uint(ext, "bufferView", UINT64_MAX, &bvi) || bvi == UINT64_MAX ||
        !ext.contains("attributes") || !ext["attributes"].is_object())
        return fail(OBS_STATUS_PARSE_ERROR, "%s: needs a bufferView and an attributes object", what.c_str());
    Json &views = doc_["bufferViews"];
    if (!views.is_array() || bvi >= views.size() || !views[static_cast<size_t>(bvi)].is_object())
        return fail(OBS_STATUS_PARSE_ERROR, "%s: bufferView %llu out of range", what.c_str(),
                    static_cast<unsigned long long>(bvi));
    const Json &bv = views[static_cast<size_t>(bvi)];
    uint64_t buf, off, len;
    if (!json_uint(bv, "buffer", UINT64_MAX, &buf) || !json_uint(bv, "byteOffset", 0, &off) ||
        !json_uint(bv, "byteLength", UINT64_MAX, &len) || buf == UINT64_MAX || len == UINT64_MAX)
        return fail(OBS_STATUS_PARSE_ERROR, "%s: bufferView %llu needs buffer and byteLength", what.c_str(),
                    static_cast<unsigned long long>(bvi));
    Json &accs = doc_["accessors"];
    if (!accs.is_array())
        return fail(OBS_STATUS_PARSE_ERROR, "%s: no accessors", what.c_str());
    if (decoded.size() != accs.size())
        decoded.assign(accs.size(), false);
    if (!prim.contains("attributes") || !prim["attributes"].is_object())
        return fail(OBS_STATUS_PARSE_ERROR, "%s: no attributes", what.c_str());
    /* the accessors the decoded data goes to, and their counts against the limits, first */
    auto acc_at = [&](const Json &idx, const char *name, uint64_t *ai) -> obs_status {
        if (!idx.is_number_unsigned() || idx.get<uint64_t>() >= accs.size() || !accs[idx.get<size_t>()].is_object())
            return fail(OBS_STATUS_PARSE_ERROR, "%s: %s accessor out of range", what.c_str(), name);
        *ai = idx.get<uint64_t>();
        if (decoded[static_cast<size_t>(*ai)])
            return fail(OBS_STATUS_UNSUPPORTED, "%s: accessor %llu (%s) is shared with another Draco primitive",
                        what.c_str(), static_cast<unsigned long long>(*ai), name);
        return OBS_STATUS_OK;
    };
    if (!prim.contains("indices"))
        return fail(OBS_STATUS_UNSUPPORTED, "%s: a Draco primitive without indices", what.c_str());
    uint64_t idx_acc, idx_count, idx_ct;
    obs_status st = acc_at(prim["indices"], "indices", &idx_acc);
    if (st != OBS_STATUS_OK)
        return st;
    Json &ia = accs[static_cast<size_t>(idx_acc)];
    if (!json_uint(ia, "count", UINT64_MAX, &idx_count) || idx_count == UINT64_MAX ||
        !json_uint(ia, "componentType", 0, &idx_ct) ||
        (idx_ct != TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE && idx_ct != TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT &&
         idx_ct != TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT))
        return fail(OBS_STATUS_PARSE_ERROR, "%s: indices accessor %llu needs a count and an unsigned componentType",
                    what.c_str(), static_cast<unsigned long long>(idx_acc));
    if (idx_count / 3 > static_cast<uint64_t>(lim_.max_triangles))
        return fail(OBS_STATUS_LIMIT_EXCEEDED, "%s: %llu triangles over the limit of %lld (raise it with --max-triangles)",
                    what.c_str(), static_cast<unsigned long long>(idx_count / 3), static_cast<long long>(lim_.max_triangles));
    const unsigned char *data = nullptr;
    if ((st = slice(buf, off, len, what, &data)) != OBS_STATUS_OK)
        return st;

    /* decode */
    draco::DecoderBuffer db;
    db.Init(reinterpret_cast<const char *>(data), static_cast<size_t>(len));
    auto type = draco::Decoder::GetEncodedGeometryType(&db);
    if (!type.ok() || type.value() != draco::TRIANGULAR_MESH)
        return fail(OBS_STATUS_PARSE_ERROR, "%s: bufferView %llu is not a Draco triangle mesh%s%s", what.c_str(),
                    static_cast<unsigned long long>(bvi), type.ok() ? "" : ": ",
                    type.ok() ? "" : one_line(type.status().error_msg_string()).c_str());
    draco::Decoder dec;
    auto res = dec.DecodeMeshFromBuffer(&db);
    if (!res.ok())
        return fail(OBS_STATUS_PARSE_ERROR, "%s: Draco cannot decode bufferView %llu: %s", what.c_str(),
                    static_cast<unsigned long long>(bvi), one_line(res.status().error_msg_string()).c_str());
    std::unique_ptr<draco::Mesh> mesh = std::move(res).value();
    const uint64_t npts = mesh->num_points(), nfaces = mesh->num_faces();
    if (nfaces * 3 != idx_count)
        return fail(OBS_STATUS_PARSE_ERROR, "%s: Draco decoded %llu faces, the indices accessor %llu says %llu indices",
                    what.c_str(), static_cast<unsigned long long>(nfaces), static_cast<unsigned long long>(idx_acc),
                    static_cast<unsigned long long>(idx_count));
    if (npts > static_cast<uint64_t>(lim_.max_vertices))
        return fail(OBS_STATUS_LIMIT_EXCEEDED, "%s: %llu vertices over the limit of %lld (raise it with --max-vertices)",
                    what.c_str(), static_cast<unsigned long long>(npts), static_cast<long long>(lim_.max_vertices));

    auto add_view = [&](size_t from, uint64_t acc) {
        Json v = Json::object();
        v["buffer"] = doc_["buffers"].size(); /* the buffer appended at the end of draco() */
        v["byteOffset"] = from;
        v["byteLength"] = out.size() - from;
        views.push_back(v);
        Json &a = accs[static_cast<size_t>(acc)];
        a["bufferView"] = views.size() - 1;
        a["byteOffset"] = 0;
        decoded[static_cast<size_t>(acc)] = true;
        while (out.size() % 4)
            out.push_back(0);
    };
    /* indices, in the accessor's component type */
    const uint64_t isz = idx_ct == TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE ? 1 : idx_ct == TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT ? 2 : 4;
    const uint64_t imax = isz == 1 ? 0xFFull : isz == 2 ? 0xFFFFull : 0xFFFFFFFFull;
    if ((st = reserve(idx_count * isz, what)) != OBS_STATUS_OK)
        return st;
    size_t from = out.size();
    out.resize(from + static_cast<size_t>(idx_count * isz));
    unsigned char *ip = out.data() + from;
    for (draco::FaceIndex f(0); f < mesh->num_faces(); ++f) {
        const draco::Mesh::Face &face = mesh->face(f);
        for (int k = 0; k < 3; k++) {
            uint64_t v = face[k].value();
            if (v >= npts || v > imax)
                return fail(OBS_STATUS_PARSE_ERROR, "%s: decoded index %llu does not fit (%llu points, %s indices)",
                            what.c_str(), static_cast<unsigned long long>(v), static_cast<unsigned long long>(npts),
                            component_name(static_cast<int>(idx_ct)));
            if (isz == 1) {
                *ip = static_cast<unsigned char>(v);
            } else if (isz == 2) {
                uint16_t s = static_cast<uint16_t>(v);
                memcpy(ip, &s, 2);
            } else {
                uint32_t s = static_cast<uint32_t>(v);
                memcpy(ip, &s, 4);
            }
            ip += isz;
        }
    }
    add_view(from, idx_acc);
    /* POSITION and NORMAL as FLOAT VEC3 */
    for (const char *name : {"POSITION", "NORMAL"}) {
        if (!ext["attributes"].contains(name) || !prim["attributes"].contains(name))
            continue;
        uint64_t acc, count, ct;
        if ((st = acc_at(prim["attributes"][name], name, &acc)) != OBS_STATUS_OK)
            return st;
        Json &a = accs[static_cast<size_t>(acc)];
        if (!json_uint(a, "count", UINT64_MAX, &count) || !json_uint(a, "componentType", 0, &ct) ||
            !a.contains("type") || a["type"] != "VEC3")
            return fail(OBS_STATUS_PARSE_ERROR, "%s: %s accessor %llu needs a count, componentType and type VEC3",
                        what.c_str(), name, static_cast<unsigned long long>(acc));
        if (ct != TINYGLTF_COMPONENT_TYPE_FLOAT)
            return fail(OBS_STATUS_UNSUPPORTED, "%s: %s accessor %llu is %s; Draco attributes are read as FLOAT only",
                        what.c_str(), name, static_cast<unsigned long long>(acc), component_name(static_cast<int>(ct)));
        if (count != npts)
            return fail(OBS_STATUS_PARSE_ERROR, "%s: %s accessor %llu count %llu != %llu decoded points", what.c_str(),
                        name, static_cast<unsigned long long>(acc), static_cast<unsigned long long>(count),
                        static_cast<unsigned long long>(npts));
        const Json &id = ext["attributes"][name];
        if (!id.is_number_unsigned() || id.get<uint64_t>() > UINT32_MAX)
            return fail(OBS_STATUS_PARSE_ERROR, "%s: %s: Draco attribute id is not an unsigned integer", what.c_str(), name);
        const draco::PointAttribute *att = mesh->GetAttributeByUniqueId(id.get<uint32_t>());
        if (!att || att->num_components() != 3)
            return fail(OBS_STATUS_PARSE_ERROR, "%s: %s: the Draco mesh has no 3-component attribute with id %llu",
                        what.c_str(), name, static_cast<unsigned long long>(id.get<uint64_t>()));
        if ((st = reserve(npts * 12, what)) != OBS_STATUS_OK)
            return st;
        from = out.size();
        out.resize(from + static_cast<size_t>(npts * 12));
        float *fp = reinterpret_cast<float *>(out.data() + from); /* vector data: aligned for float */
        for (draco::PointIndex p(0); p < mesh->num_points(); ++p) {
            draco::AttributeValueIndex vi = att->mapped_index(p);
            if (vi.value() >= att->size() || !att->ConvertValue<float>(vi, 3, fp + 3 * p.value()))
                return fail(OBS_STATUS_PARSE_ERROR, "%s: %s value %u does not convert", what.c_str(), name, p.value());
        }
        add_view(from, acc);
    }
    prim["extensions"].erase("KHR_draco_mesh_compression");
    if (prim["extensions"].empty())
        prim.erase("extensions");
    return OBS_STATUS_OK;
}

obs_status Preflight::draco()
{
    auto meshes = doc_.find("meshes");
    if (meshes == doc_.end() || !meshes->is_array())
        return OBS_STATUS_OK;
    std::vector<unsigned char> out;
    std::vector<bool> decoded;
    bool any = false;
    for (size_t mi = 0; mi < meshes->size(); mi++) {
        Json &m = (*meshes)[mi];
        if (!m.is_object() || !m.contains("primitives") || !m["primitives"].is_array())
            continue;
        for (size_t pi = 0; pi < m["primitives"].size(); pi++) {
            Json &prim = m["primitives"][pi];
            if (!prim.is_object() || !prim.contains("extensions") || !prim["extensions"].is_object() ||
                !prim["extensions"].contains("KHR_draco_mesh_compression"))
                continue;
            if (!doc_.contains("buffers") || !doc_["buffers"].is_array())
                return fail(OBS_STATUS_PARSE_ERROR, "Draco primitives but no buffers");
            obs_status st = draco_primitive(mi, pi, prim, out, decoded);
            if (st != OBS_STATUS_OK)
                return st;
            any = true;
        }
    }
    if (any) {
        Json b = Json::object();
        b["byteLength"] = out.size() ? out.size() : 4;
        if (out.empty())
            out.assign(4, 0);
        b["uri"] = base64_data_uri(out);
        doc_["buffers"].push_back(b);
    }
    return OBS_STATUS_OK;
}

/* the rewritten document: the JSON text for a .gltf, or a GLB with the new JSON chunk and the
 * original BIN chunk */
obs_status Preflight::rebuild(uint32_t *glb_len)
{
    for (const char *key : {"extensionsRequired", "extensionsUsed"}) {
        auto it = doc_.find(key);
        if (it == doc_.end() || !it->is_array())
            continue;
        Json keep = Json::array();
        for (const Json &e : *it)
            if (!(e == "KHR_draco_mesh_compression" || e == "EXT_meshopt_compression"))
                keep.push_back(e);
        *it = keep;
    }
    std::string js = doc_.dump();
    if (!binary_) {
        if (js.size() > 0xFFFFFFFFull)
            return fail(OBS_STATUS_LIMIT_EXCEEDED, "decoded document over 4 GiB");
        bytes_.assign(js.begin(), js.end());
        return OBS_STATUS_OK;
    }
    while (js.size() % 4)
        js += ' ';
    uint64_t total = 12 + 8 + js.size() + (bin_ ? 8 + bin_len_ : 0);
    if (total > 0xFFFFFFFFull)
        return fail(OBS_STATUS_LIMIT_EXCEEDED, "decoded GLB over 4 GiB");
    std::vector<unsigned char> g;
    g.reserve(static_cast<size_t>(total));
    auto le32 = [&g](uint64_t v) {
        for (int k = 0; k < 4; k++)
            g.push_back(static_cast<unsigned char>(v >> (8 * k)));
    };
    g.insert(g.end(), {'g', 'l', 'T', 'F'});
    le32(2);
    le32(total);
    le32(js.size());
    le32(0x4E4F534Au);
    g.insert(g.end(), js.begin(), js.end());
    if (bin_) {
        le32(bin_len_);
        le32(0x004E4942u);
        g.insert(g.end(), bin_, bin_ + bin_len_);
    }
    bytes_.swap(g);
    *glb_len = static_cast<uint32_t>(total);
    return OBS_STATUS_OK;
}

obs_status Preflight::run(uint32_t *glb_len)
{
    const unsigned char *js = bytes_.data();
    size_t jn = bytes_.size();
    if (binary_) { /* check_glb has proven the chunk layout */
        jn = rd_le32(&bytes_[12]);
        js = &bytes_[20];
        uint64_t off = 20 + jn;
        if (off + 8 <= *glb_len) {
            bin_len_ = rd_le32(&bytes_[static_cast<size_t>(off)]);
            bin_ = &bytes_[static_cast<size_t>(off) + 8];
        }
    }
    doc_ = Json::parse(js, js + jn, nullptr, false);
    if (doc_.is_discarded() || !doc_.is_object())
        return OBS_STATUS_OK; /* malformed JSON: tinygltf reports it in its own words */
    obs_status st;
    if ((st = check_asset()) != OBS_STATUS_OK || (st = check_required()) != OBS_STATUS_OK)
        return st;
    bool compressed = false;
    const std::string text(reinterpret_cast<const char *>(js), jn);
    if (text.find("EXT_meshopt_compression") != std::string::npos) {
        if ((st = meshopt()) != OBS_STATUS_OK)
            return st;
        compressed = true;
    }
    if (text.find("KHR_draco_mesh_compression") != std::string::npos) {
        if ((st = draco()) != OBS_STATUS_OK)
            return st;
        compressed = true;
    }
    if (!compressed)
        return OBS_STATUS_OK;
    loaded_.clear();
    return rebuild(glb_len);
}

/* ---- the loader ------------------------------------------------------------------------------ */

struct AccessorView {
    const unsigned char *base = nullptr; /* NULL: no bufferView, all zeros */
    uint64_t stride = 0;
    uint64_t count = 0;
    int component_type = 0;
    bool normalized = false;
};

class Loader {
public:
    /* mem != NULL: parse the mem_len bytes there instead of reading the file `path`, which then
     * only names them in messages */
    Loader(obs_context *ctx, const char *path, const io_gltf_options &opt, obs_scene *out,
           const void *mem = nullptr, size_t mem_len = 0)
        : ctx_(ctx), path_(path), opt_(opt), out_(out), mem_(static_cast<const unsigned char *>(mem)),
          mem_len_(mem_len)
    {
        lim_ = ctx ? *obs_context_limits(ctx) : obs_limits_default();
    }

    obs_status run();

private:
    obs_status fail(obs_status st, const char *fmt, ...) __attribute__((format(printf, 3, 4)));
    obs_status read_file(std::vector<unsigned char> &bytes);
    obs_status check_glb(const std::vector<unsigned char> &bytes, uint32_t *length);
    obs_status parse(std::vector<unsigned char> &bytes);
    obs_status preflight(std::vector<unsigned char> &bytes, bool binary, uint32_t *glb_len);
    obs_status check_extensions();
    obs_status accessor(int index, const std::string &what, int kind, AccessorView *v);
    obs_status load_meshes();
    obs_status load_primitive(int mi, int pi, const tinygltf::Primitive &prim);
    obs_status load_materials();
    obs_status check_node_graph();
    obs_status local_matrix(int n, obs_mat4 *m);
    obs_status walk();
    obs_status add_camera(int node, const obs_mat4 &world);
    obs_status add_light(int node, int light, const obs_mat4 &world);
    obs_status commit();

    std::string mesh_desc(int mi, int pi) const
    {
        std::string s = "mesh " + std::to_string(mi);
        const std::string &nm = model_.meshes[static_cast<size_t>(mi)].name;
        if (!nm.empty())
            s += " '" + nm + "'";
        return s + " primitive " + std::to_string(pi);
    }

    obs_context *ctx_;
    const char *path_;
    io_gltf_options opt_;
    obs_scene *out_;
    const unsigned char *mem_;
    size_t mem_len_;
    obs_limits lim_;
    tinygltf::Model model_;
    FsState fs_;
    uint64_t total_vertices_ = 0, total_triangles_ = 0;
    bool quantization_ = false; /* KHR_mesh_quantization in extensionsUsed */
    std::vector<std::vector<uint32_t>> mesh_map_; /* glTF mesh -> obs mesh indices */
    std::vector<obs_instance> instances_;
    std::vector<obs_camera> cameras_;
    std::vector<obs_light> lights_;
};

enum { KIND_POSITION = 0, KIND_NORMAL = 1, KIND_INDEX = 2 };

obs_status Loader::fail(obs_status st, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    obs_status r = fail_v(ctx_, path_, st, fmt, ap);
    va_end(ap);
    return r;
}

obs_status Loader::read_file(std::vector<unsigned char> &bytes)
{
    if (mem_) {
        if (static_cast<uint64_t>(mem_len_) > 0xFFFFFFFFull || static_cast<int64_t>(mem_len_) > lim_.max_memory_bytes)
            return fail(OBS_STATUS_LIMIT_EXCEEDED, "%zu bytes are too many to load (limit %llu; --max-memory)",
                        mem_len_,
                        static_cast<unsigned long long>(lim_.max_memory_bytes < 0xFFFFFFFFll ? lim_.max_memory_bytes
                                                                                             : 0xFFFFFFFFll));
        bytes.assign(mem_, mem_ + mem_len_);
        if (bytes.empty())
            return fail(OBS_STATUS_PARSE_ERROR, "empty file");
        return OBS_STATUS_OK;
    }
    FILE *f = fopen(path_, "rb");
    if (!f)
        return fail(OBS_STATUS_IO_ERROR, "cannot open: %s", strerror(errno));
    struct stat sb;
    if (fstat(fileno(f), &sb) != 0) {
        int e = errno;
        fclose(f);
        return fail(OBS_STATUS_IO_ERROR, "cannot stat: %s", strerror(e));
    }
    if (!S_ISREG(sb.st_mode)) {
        fclose(f);
        return fail(OBS_STATUS_IO_ERROR, "not a regular file");
    }
    uint64_t size = static_cast<uint64_t>(sb.st_size);
    /* tinygltf takes 32-bit lengths */
    if (size > 0xFFFFFFFFull || static_cast<int64_t>(size) > lim_.max_memory_bytes) {
        fclose(f);
        return fail(OBS_STATUS_LIMIT_EXCEEDED, "file of %llu bytes is too large to load (limit %llu; --max-memory)",
                    static_cast<unsigned long long>(size),
                    static_cast<unsigned long long>(lim_.max_memory_bytes < 0xFFFFFFFFll ? lim_.max_memory_bytes
                                                                                         : 0xFFFFFFFFll));
    }
    bytes.resize(static_cast<size_t>(size));
    size_t got = size ? fread(bytes.data(), 1, bytes.size(), f) : 0;
    int bad = ferror(f);
    fclose(f);
    if (bad || got != bytes.size())
        return fail(OBS_STATUS_IO_ERROR, "read error (%zu of %zu bytes read)", got, bytes.size());
    if (bytes.empty())
        return fail(OBS_STATUS_PARSE_ERROR, "empty file");
    return OBS_STATUS_OK;
}

/* Strict GLB container check (glTF 2.0 spec, section 4.4 "Binary glTF Layout"). */
obs_status Loader::check_glb(const std::vector<unsigned char> &b, uint32_t *length)
{
    const uint64_t size = b.size();
    if (size < 12)
        return fail(OBS_STATUS_PARSE_ERROR, "truncated GLB: %llu bytes, shorter than the 12-byte header",
                    static_cast<unsigned long long>(size));
    if (memcmp(b.data(), "glTF", 4) != 0)
        return fail(OBS_STATUS_PARSE_ERROR, "not a GLB file (no 'glTF' magic)");
    uint32_t version = rd_le32(&b[4]);
    if (version != 2)
        return fail(OBS_STATUS_UNSUPPORTED, "GLB container version %u (only 2 is supported)", version);
    uint64_t len = rd_le32(&b[8]);
    if (len > size)
        return fail(OBS_STATUS_PARSE_ERROR, "truncated GLB: header length %llu > file size %llu",
                    static_cast<unsigned long long>(len), static_cast<unsigned long long>(size));
    if (len < 20)
        return fail(OBS_STATUS_PARSE_ERROR, "truncated GLB: length %llu leaves no room for the JSON chunk",
                    static_cast<unsigned long long>(len));
    uint64_t c0len = rd_le32(&b[12]);
    uint32_t c0type = rd_le32(&b[16]);
    if (c0type != 0x4E4F534Au)
        return fail(OBS_STATUS_PARSE_ERROR, "GLB: first chunk is not JSON (type 0x%08x)", c0type);
    if (c0len == 0 || 20 + c0len > len)
        return fail(OBS_STATUS_PARSE_ERROR, "truncated GLB: JSON chunk of %llu bytes at offset 20 > length %llu",
                    static_cast<unsigned long long>(c0len), static_cast<unsigned long long>(len));
    uint64_t off = 20 + c0len;
    if (off < len) {
        if (len - off < 8)
            return fail(OBS_STATUS_PARSE_ERROR, "truncated GLB: %llu stray bytes after the JSON chunk",
                        static_cast<unsigned long long>(len - off));
        uint64_t c1len = rd_le32(&b[static_cast<size_t>(off)]);
        uint32_t c1type = rd_le32(&b[static_cast<size_t>(off) + 4]);
        if (off + 8 + c1len > len)
            return fail(OBS_STATUS_PARSE_ERROR,
                        "truncated GLB: chunk 1 of %llu bytes at offset %llu + 8 > length %llu",
                        static_cast<unsigned long long>(c1len), static_cast<unsigned long long>(off),
                        static_cast<unsigned long long>(len));
        if (c1type != 0x004E4942u)
            return fail(OBS_STATUS_PARSE_ERROR, "GLB: second chunk is not BIN (type 0x%08x)", c1type);
        if (c1len < 4 || c1len % 4 != 0)
            return fail(OBS_STATUS_PARSE_ERROR, "GLB: BIN chunk length %llu is not a positive multiple of 4",
                        static_cast<unsigned long long>(c1len));
    }
    if (len < size)
        obs_log(ctx_, OBS_LOG_WARN, "%s: %llu bytes after the GLB length %llu ignored", path_,
                static_cast<unsigned long long>(size - len), static_cast<unsigned long long>(len));
    if (!json_depth_ok(&b[20], static_cast<size_t>(c0len), kMaxJsonDepth))
        return fail(OBS_STATUS_PARSE_ERROR, "JSON nested deeper than %d levels", kMaxJsonDepth);
    *length = static_cast<uint32_t>(len);
    return OBS_STATUS_OK;
}

obs_status Loader::preflight(std::vector<unsigned char> &bytes, bool binary, uint32_t *glb_len)
{
    try {
        Preflight p(ctx_, path_, lim_, fs_, bytes, binary);
        return p.run(glb_len);
    } catch (const std::bad_alloc &) {
        return fail(OBS_STATUS_OUT_OF_MEMORY, "out of memory while reading the glTF JSON or decoding compressed data");
    } catch (const std::exception &e) {
        return fail(OBS_STATUS_PARSE_ERROR, "malformed glTF JSON: %s", one_line(e.what()).c_str());
    }
}

obs_status Loader::parse(std::vector<unsigned char> &bytes)
{
    obs_status st = read_file(bytes);
    if (st != OBS_STATUS_OK)
        return st;

    std::string ext = lower_ext(path_);
    bool binary = ext == "glb" || (bytes.size() >= 4 && memcmp(bytes.data(), "glTF", 4) == 0);

    fs_.base = mem_ ? std::string() : base_dir(path_);
    fs_.memory = mem_ != nullptr;
    fs_.max_bytes = static_cast<uint64_t>(lim_.max_memory_bytes > 0 ? lim_.max_memory_bytes : 0);
    if (fs_.max_bytes > 0xFFFFFFFFull)
        fs_.max_bytes = 0xFFFFFFFFull;

    tinygltf::TinyGLTF gltf;
    tinygltf::FsCallbacks cb;
    cb.FileExists = fs_file_exists;
    cb.ExpandFilePath = fs_expand;
    cb.ReadWholeFile = fs_read;
    cb.WriteWholeFile = fs_write;
    cb.user_data = &fs_;
    gltf.SetFsCallbacks(cb);
    gltf.SetImageLoader(no_image_decode, nullptr);

    std::string err, warn;
    bool ok;
    if (binary) {
        uint32_t len = 0;
        st = check_glb(bytes, &len);
        if (st != OBS_STATUS_OK)
            return st;
        if ((st = preflight(bytes, true, &len)) != OBS_STATUS_OK)
            return st;
        ok = gltf.LoadBinaryFromMemory(&model_, &err, &warn, bytes.data(), len, fs_.base);
    } else {
        if (!json_depth_ok(bytes.data(), bytes.size(), kMaxJsonDepth))
            return fail(OBS_STATUS_PARSE_ERROR, "JSON nested deeper than %d levels", kMaxJsonDepth);
        uint32_t unused = 0;
        if ((st = preflight(bytes, false, &unused)) != OBS_STATUS_OK)
            return st;
        ok = gltf.LoadASCIIFromString(&model_, &err, &warn, reinterpret_cast<const char *>(bytes.data()),
                                      static_cast<unsigned int>(bytes.size()), fs_.base);
    }
    if (!warn.empty())
        obs_log(ctx_, OBS_LOG_WARN, "%s: tinygltf: %s", path_, one_line(warn).c_str());
    if (!ok) {
        if (fs_.memory && (err.find("File not found") != std::string::npos ||
                           err.find("File read error") != std::string::npos))
            return fail(OBS_STATUS_IO_ERROR,
                        "an external buffer cannot be resolved when loading from memory (only the GLB BIN chunk "
                        "and data: URIs can be): %s",
                        one_line(err).c_str());
        if (err.find("File not found") != std::string::npos)
            return fail(OBS_STATUS_IO_ERROR, "cannot load an external buffer (looked in '%s'): %s",
                        fs_.base.empty() ? "." : fs_.base.c_str(), one_line(err).c_str());
        if (err.find("File read error") != std::string::npos)
            return fail(OBS_STATUS_IO_ERROR, "cannot read an external buffer: %s", one_line(err).c_str());
        return fail(OBS_STATUS_PARSE_ERROR, "tinygltf: %s", err.empty() ? "parse failed" : one_line(err).c_str());
    }
    if (!err.empty())
        obs_log(ctx_, OBS_LOG_WARN, "%s: tinygltf: %s", path_, one_line(err).c_str());
    return OBS_STATUS_OK;
}

const char *component_name(int ct)
{
    switch (ct) {
    case TINYGLTF_COMPONENT_TYPE_BYTE: return "BYTE";
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE: return "UNSIGNED_BYTE";
    case TINYGLTF_COMPONENT_TYPE_SHORT: return "SHORT";
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT: return "UNSIGNED_SHORT";
    case TINYGLTF_COMPONENT_TYPE_INT: return "INT";
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT: return "UNSIGNED_INT";
    case TINYGLTF_COMPONENT_TYPE_FLOAT: return "FLOAT";
    case TINYGLTF_COMPONENT_TYPE_DOUBLE: return "DOUBLE";
    default: return "unknown";
    }
}

const char *type_name(int t)
{
    switch (t) {
    case TINYGLTF_TYPE_SCALAR: return "SCALAR";
    case TINYGLTF_TYPE_VEC2: return "VEC2";
    case TINYGLTF_TYPE_VEC3: return "VEC3";
    case TINYGLTF_TYPE_VEC4: return "VEC4";
    case TINYGLTF_TYPE_MAT2: return "MAT2";
    case TINYGLTF_TYPE_MAT3: return "MAT3";
    case TINYGLTF_TYPE_MAT4: return "MAT4";
    default: return "unknown";
    }
}

/* Validate accessor `index` used as `what` (e.g. "POSITION of mesh 0 primitive 1") and describe
 * where its elements lie. Nothing is read here; every byte the caller reads afterwards lies in
 * [base, base + stride*(count-1) + elementSize), which this function has proven to be inside
 * the buffer. */
obs_status Loader::accessor(int index, const std::string &what, int kind, AccessorView *v)
{
    if (index < 0 || static_cast<size_t>(index) >= model_.accessors.size())
        return fail(OBS_STATUS_PARSE_ERROR, "%s: accessor %d out of range (%zu accessors)", what.c_str(), index,
                    model_.accessors.size());
    const tinygltf::Accessor &a = model_.accessors[static_cast<size_t>(index)];
    if (a.sparse.isSparse)
        return fail(OBS_STATUS_UNSUPPORTED, "accessor %d (%s): sparse accessors are not supported", index,
                    what.c_str());
    uint64_t elem;
    if (kind == KIND_POSITION || kind == KIND_NORMAL) {
        /* FLOAT VEC3; with KHR_mesh_quantization (its README, "Extending Mesh Attributes") also
         * POSITION as (UNSIGNED_)BYTE or (UNSIGNED_)SHORT, normalized or not, and NORMAL as
         * normalized BYTE or SHORT */
        const int ct = a.componentType;
        const bool small_int = ct == TINYGLTF_COMPONENT_TYPE_BYTE || ct == TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE ||
                               ct == TINYGLTF_COMPONENT_TYPE_SHORT || ct == TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT;
        const bool is_float = ct == TINYGLTF_COMPONENT_TYPE_FLOAT && !a.normalized;
        const bool quantized = kind == KIND_POSITION ? small_int
                                                     : a.normalized && (ct == TINYGLTF_COMPONENT_TYPE_BYTE ||
                                                                        ct == TINYGLTF_COMPONENT_TYPE_SHORT);
        if (a.type != TINYGLTF_TYPE_VEC3 || !(is_float || quantized))
            return fail(OBS_STATUS_PARSE_ERROR,
                        "accessor %d (%s): wrong component type %s %s%s, expected FLOAT VEC3%s", index, what.c_str(),
                        component_name(ct), type_name(a.type), a.normalized ? " normalized" : "",
                        kind == KIND_POSITION ? " (or, with KHR_mesh_quantization, BYTE, UNSIGNED_BYTE, SHORT or "
                                                "UNSIGNED_SHORT VEC3, normalized or not)"
                                              : " (or, with KHR_mesh_quantization, normalized BYTE or SHORT VEC3)");
        if (quantized && !quantization_)
            return fail(OBS_STATUS_PARSE_ERROR,
                        "accessor %d (%s): wrong component type %s%s VEC3 without KHR_mesh_quantization (the file "
                        "does not list it in extensionsUsed)",
                        index, what.c_str(), a.normalized ? "normalized " : "", component_name(ct));
        elem = 3 * static_cast<uint64_t>(tinygltf::GetComponentSizeInBytes(static_cast<uint32_t>(ct)));
    } else {
        if (a.type != TINYGLTF_TYPE_SCALAR || a.normalized ||
            (a.componentType != TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE &&
             a.componentType != TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT &&
             a.componentType != TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT))
            return fail(OBS_STATUS_PARSE_ERROR,
                        "accessor %d (%s): wrong component type %s %s%s, expected UNSIGNED_BYTE, UNSIGNED_SHORT or "
                        "UNSIGNED_INT SCALAR",
                        index, what.c_str(), component_name(a.componentType), type_name(a.type),
                        a.normalized ? " normalized" : "");
        elem = static_cast<uint64_t>(tinygltf::GetComponentSizeInBytes(static_cast<uint32_t>(a.componentType)));
    }
    const uint64_t count = a.count;
    if (count == 0)
        return fail(OBS_STATUS_PARSE_ERROR, "accessor %d (%s): count 0 (the minimum is 1)", index, what.c_str());

    v->count = count;
    v->component_type = a.componentType;
    v->normalized = a.normalized;
    v->stride = elem;
    v->base = nullptr;
    if (a.bufferView == -1)
        return OBS_STATUS_OK; /* spec: no bufferView means all zeros */
    if (a.bufferView < 0 || static_cast<size_t>(a.bufferView) >= model_.bufferViews.size())
        return fail(OBS_STATUS_PARSE_ERROR, "accessor %d (%s): bufferView %d out of range (%zu bufferViews)", index,
                    what.c_str(), a.bufferView, model_.bufferViews.size());
    const tinygltf::BufferView &bv = model_.bufferViews[static_cast<size_t>(a.bufferView)];
    if (bv.buffer < 0 || static_cast<size_t>(bv.buffer) >= model_.buffers.size())
        return fail(OBS_STATUS_PARSE_ERROR, "bufferView %d: buffer %d out of range (%zu buffers)", a.bufferView,
                    bv.buffer, model_.buffers.size());
    const tinygltf::Buffer &buf = model_.buffers[static_cast<size_t>(bv.buffer)];
    uint64_t bv_end;
    if (!add_u64(bv.byteOffset, bv.byteLength, &bv_end) || bv_end > buf.data.size())
        return fail(OBS_STATUS_PARSE_ERROR, "bufferView %d (buffer %d): byteOffset %llu + byteLength %llu > buffer size %zu",
                    a.bufferView, bv.buffer, static_cast<unsigned long long>(bv.byteOffset),
                    static_cast<unsigned long long>(bv.byteLength), buf.data.size());
    uint64_t stride = bv.byteStride ? static_cast<uint64_t>(bv.byteStride) : elem;
    if (stride < elem)
        return fail(OBS_STATUS_PARSE_ERROR, "accessor %d (bufferView %d): byteStride %llu < element size %llu", index,
                    a.bufferView, static_cast<unsigned long long>(stride), static_cast<unsigned long long>(elem));
    uint64_t span, end;
    if (!mul_u64(stride, count - 1, &span) || !add_u64(span, a.byteOffset, &end) || !add_u64(end, elem, &end) ||
        end > bv.byteLength)
        return fail(OBS_STATUS_PARSE_ERROR,
                    "accessor %d (bufferView %d): byteOffset %llu + stride %llu * (count %llu - 1) + %llu > byteLength %llu",
                    index, a.bufferView, static_cast<unsigned long long>(a.byteOffset),
                    static_cast<unsigned long long>(stride), static_cast<unsigned long long>(count),
                    static_cast<unsigned long long>(elem), static_cast<unsigned long long>(bv.byteLength));
    v->stride = stride;
    v->base = buf.data.data() + bv.byteOffset + a.byteOffset;
    return OBS_STATUS_OK;
}

const char *mode_name(int mode)
{
    switch (mode) {
    case TINYGLTF_MODE_POINTS: return "POINTS";
    case TINYGLTF_MODE_LINE: return "LINES";
    case TINYGLTF_MODE_LINE_LOOP: return "LINE_LOOP";
    case TINYGLTF_MODE_LINE_STRIP: return "LINE_STRIP";
    case TINYGLTF_MODE_TRIANGLES: return "TRIANGLES";
    case TINYGLTF_MODE_TRIANGLE_STRIP: return "TRIANGLE_STRIP";
    case TINYGLTF_MODE_TRIANGLE_FAN: return "TRIANGLE_FAN";
    default: return "unknown";
    }
}

/* One component of a quantized attribute as float. Normalized integers follow the glTF 2.0 spec,
 * 3.11 "Animations" table of normalized types (also KHR_mesh_quantization's README):
 * f = max(c / 127, -1), c / 255, max(c / 32767, -1), c / 65535; others are the integer value. */
float dequantize(const unsigned char *p, int ct, bool normalized)
{
    switch (ct) {
    case TINYGLTF_COMPONENT_TYPE_BYTE: {
        int8_t c;
        memcpy(&c, p, 1);
        return normalized ? std::fmax(c / 127.0f, -1.0f) : static_cast<float>(c);
    }
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE: return normalized ? p[0] / 255.0f : static_cast<float>(p[0]);
    case TINYGLTF_COMPONENT_TYPE_SHORT: {
        int16_t c;
        memcpy(&c, p, 2);
        return normalized ? std::fmax(c / 32767.0f, -1.0f) : static_cast<float>(c);
    }
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT: {
        uint16_t c;
        memcpy(&c, p, 2);
        return normalized ? c / 65535.0f : static_cast<float>(c);
    }
    default: return 0.0f; /* not reached: accessor() admits only these and FLOAT */
    }
}

void read_vec3f(const AccessorView &v, float *dst)
{
    if (!v.base) {
        memset(dst, 0, static_cast<size_t>(v.count) * 12);
        return;
    }
    if (v.component_type == TINYGLTF_COMPONENT_TYPE_FLOAT) {
        for (uint64_t i = 0; i < v.count; i++)
            memcpy(dst + 3 * i, v.base + i * v.stride, 12);
        return;
    }
    const uint64_t cs = static_cast<uint64_t>(tinygltf::GetComponentSizeInBytes(static_cast<uint32_t>(v.component_type)));
    for (uint64_t i = 0; i < v.count; i++)
        for (uint64_t k = 0; k < 3; k++)
            dst[3 * i + k] = dequantize(v.base + i * v.stride + k * cs, v.component_type, v.normalized);
}

obs_status Loader::load_primitive(int mi, int pi, const tinygltf::Primitive &prim)
{
    const std::string desc = mesh_desc(mi, pi);
    int mode = prim.mode == -1 ? TINYGLTF_MODE_TRIANGLES : prim.mode;
    if (mode != TINYGLTF_MODE_TRIANGLES) {
        if (opt_.require_triangles)
            return fail(OBS_STATUS_UNSUPPORTED, "%s: mode %d (%s) is not supported, only TRIANGLES (4)", desc.c_str(),
                        mode, mode_name(mode));
        obs_log(ctx_, OBS_LOG_WARN, "%s: %s: mode %d (%s) skipped, only TRIANGLES are loaded", path_, desc.c_str(),
                mode, mode_name(mode));
        return OBS_STATUS_OK;
    }
    auto pos_it = prim.attributes.find("POSITION");
    if (pos_it == prim.attributes.end()) {
        obs_log(ctx_, OBS_LOG_WARN, "%s: %s has no POSITION attribute; skipped", path_, desc.c_str());
        return OBS_STATUS_OK;
    }
    if (prim.material != -1 && (prim.material < 0 || static_cast<size_t>(prim.material) >= model_.materials.size()))
        return fail(OBS_STATUS_PARSE_ERROR, "%s: material %d out of range (%zu materials)", desc.c_str(), prim.material,
                    model_.materials.size());

    AccessorView pos, nrm, idx;
    obs_status st = accessor(pos_it->second, "POSITION of " + desc, KIND_POSITION, &pos);
    if (st != OBS_STATUS_OK)
        return st;
    auto nrm_it = prim.attributes.find("NORMAL");
    bool has_normals = nrm_it != prim.attributes.end();
    if (has_normals) {
        st = accessor(nrm_it->second, "NORMAL of " + desc, KIND_NORMAL, &nrm);
        if (st != OBS_STATUS_OK)
            return st;
        if (nrm.count != pos.count)
            return fail(OBS_STATUS_PARSE_ERROR, "%s: NORMAL count %llu != POSITION count %llu", desc.c_str(),
                        static_cast<unsigned long long>(nrm.count), static_cast<unsigned long long>(pos.count));
    }
    bool indexed = prim.indices != -1;
    uint64_t nidx = pos.count;
    if (indexed) {
        st = accessor(prim.indices, "indices of " + desc, KIND_INDEX, &idx);
        if (st != OBS_STATUS_OK)
            return st;
        nidx = idx.count;
    }
    if (nidx % 3 != 0)
        return fail(OBS_STATUS_PARSE_ERROR, "%s: %s count %llu is not a multiple of 3", desc.c_str(),
                    indexed ? "index" : "vertex (non-indexed)", static_cast<unsigned long long>(nidx));
    const uint64_t nverts = pos.count, ntris = nidx / 3;

    /* limits, before any allocation */
    if (nverts > UINT32_MAX || static_cast<int64_t>(total_vertices_ + nverts) > lim_.max_vertices)
        return fail(OBS_STATUS_LIMIT_EXCEEDED,
                    "%s: %llu vertices (%llu in the scene so far) over the limit of %lld (raise it with --max-vertices)",
                    desc.c_str(), static_cast<unsigned long long>(nverts),
                    static_cast<unsigned long long>(total_vertices_), static_cast<long long>(lim_.max_vertices));
    if (ntris > UINT32_MAX / 3 || static_cast<int64_t>(total_triangles_ + ntris) > lim_.max_triangles)
        return fail(OBS_STATUS_LIMIT_EXCEEDED,
                    "%s: %llu triangles (%llu in the scene so far) over the limit of %lld (raise it with --max-triangles)",
                    desc.c_str(), static_cast<unsigned long long>(ntris),
                    static_cast<unsigned long long>(total_triangles_), static_cast<long long>(lim_.max_triangles));
    uint64_t bytes = nverts * 12 * (has_normals ? 2 : 1) + nidx * 4;
    if (static_cast<int64_t>(bytes) > lim_.max_memory_bytes)
        return fail(OBS_STATUS_LIMIT_EXCEEDED, "%s: %llu bytes of mesh data over the limit of %lld (--max-memory)",
                    desc.c_str(), static_cast<unsigned long long>(bytes), static_cast<long long>(lim_.max_memory_bytes));
    /* index values are checked before allocating too (no allocation for a bad file) */
    if (indexed && idx.base) {
        for (uint64_t i = 0; i < nidx; i++) {
            const unsigned char *p = idx.base + i * idx.stride;
            uint32_t val;
            if (idx.component_type == TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE) {
                val = p[0];
            } else if (idx.component_type == TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT) {
                uint16_t s;
                memcpy(&s, p, 2);
                val = s;
            } else {
                memcpy(&val, p, 4);
            }
            if (val >= nverts)
                return fail(OBS_STATUS_PARSE_ERROR, "%s: index %llu (accessor %d) is %u, not below the vertex count %llu",
                            desc.c_str(), static_cast<unsigned long long>(i), prim.indices, val,
                            static_cast<unsigned long long>(nverts));
        }
    }
    total_vertices_ += nverts;
    total_triangles_ += ntris;

    /* the mesh slot is counted first, so obs_scene_free releases whatever is allocated below */
    obs_mesh *m = &out_->meshes[out_->mesh_count];
    memset(m, 0, sizeof *m);
    uint32_t mesh_index = out_->mesh_count++;
    {
        const std::string &nm = model_.meshes[static_cast<size_t>(mi)].name;
        copy_name(m->name, (nm.empty() ? "mesh" + std::to_string(mi) : nm) + "/prim" + std::to_string(pi));
    }
    m->material = prim.material;
    m->vertex_count = static_cast<uint32_t>(nverts);
    m->triangle_count = static_cast<uint32_t>(ntris);
    m->positions = static_cast<float *>(malloc(static_cast<size_t>(nverts) * 12));
    m->indices = static_cast<uint32_t *>(malloc(static_cast<size_t>(nidx) * 4));
    if (has_normals)
        m->normals = static_cast<float *>(malloc(static_cast<size_t>(nverts) * 12));
    if (!m->positions || !m->indices || (has_normals && !m->normals))
        return fail(OBS_STATUS_OUT_OF_MEMORY, "%s: cannot allocate %llu bytes of mesh data", desc.c_str(),
                    static_cast<unsigned long long>(bytes));
    read_vec3f(pos, m->positions);
    if (has_normals)
        read_vec3f(nrm, m->normals);
    if (!indexed) {
        for (uint64_t i = 0; i < nidx; i++)
            m->indices[i] = static_cast<uint32_t>(i);
    } else if (!idx.base) {
        memset(m->indices, 0, static_cast<size_t>(nidx) * 4);
    } else {
        for (uint64_t i = 0; i < nidx; i++) {
            const unsigned char *p = idx.base + i * idx.stride;
            if (idx.component_type == TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE) {
                m->indices[i] = p[0];
            } else if (idx.component_type == TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT) {
                uint16_t s;
                memcpy(&s, p, 2);
                m->indices[i] = s;
            } else {
                memcpy(&m->indices[i], p, 4);
            }
        }
    }
    mesh_map_[static_cast<size_t>(mi)].push_back(mesh_index);
    return OBS_STATUS_OK;
}

obs_status Loader::load_meshes()
{
    size_t prims = 0;
    for (const tinygltf::Mesh &mesh : model_.meshes)
        prims += mesh.primitives.size();
    if (prims > UINT32_MAX)
        return fail(OBS_STATUS_LIMIT_EXCEEDED, "%zu primitives", prims);
    mesh_map_.assign(model_.meshes.size(), std::vector<uint32_t>());
    if (prims == 0)
        return OBS_STATUS_OK;
    out_->meshes = static_cast<obs_mesh *>(calloc(prims, sizeof(obs_mesh)));
    if (!out_->meshes)
        return fail(OBS_STATUS_OUT_OF_MEMORY, "cannot allocate %zu meshes", prims);
    for (size_t mi = 0; mi < model_.meshes.size(); mi++) {
        const tinygltf::Mesh &mesh = model_.meshes[mi];
        for (size_t pi = 0; pi < mesh.primitives.size(); pi++) {
            obs_status st = load_primitive(static_cast<int>(mi), static_cast<int>(pi), mesh.primitives[pi]);
            if (st != OBS_STATUS_OK)
                return st;
        }
    }
    return OBS_STATUS_OK;
}

obs_status Loader::load_materials()
{
    size_t n = model_.materials.size();
    if (n == 0)
        return OBS_STATUS_OK;
    if (n > UINT32_MAX)
        return fail(OBS_STATUS_LIMIT_EXCEEDED, "%zu materials", n);
    out_->materials = static_cast<obs_material *>(calloc(n, sizeof(obs_material)));
    if (!out_->materials)
        return fail(OBS_STATUS_OUT_OF_MEMORY, "cannot allocate %zu materials", n);
    out_->material_count = static_cast<uint32_t>(n); /* calloc: extras_json NULL, safe to free */
    for (size_t i = 0; i < n; i++) {
        const tinygltf::Material &src = model_.materials[i];
        obs_material *dst = &out_->materials[i];
        copy_name(dst->name, src.name);
        const std::vector<double> &bc = src.pbrMetallicRoughness.baseColorFactor;
        for (int c = 0; c < 4; c++)
            dst->base_color[c] = bc.size() == 4 ? static_cast<float>(bc[static_cast<size_t>(c)]) : 1.0f;
        dst->metallic = static_cast<float>(src.pbrMetallicRoughness.metallicFactor);
        dst->roughness = static_cast<float>(src.pbrMetallicRoughness.roughnessFactor);
        dst->double_sided = src.doubleSided ? 1 : 0;
        if (src.extras.Type() != tinygltf::NULL_TYPE) {
            std::string json;
            if (!value_to_json(json, src.extras, 0))
                return fail(OBS_STATUS_PARSE_ERROR, "material %zu: extras nested deeper than %d levels", i,
                            kMaxJsonDepth);
            dst->extras_json = static_cast<char *>(malloc(json.size() + 1));
            if (!dst->extras_json)
                return fail(OBS_STATUS_OUT_OF_MEMORY, "material %zu: cannot allocate the extras text", i);
            memcpy(dst->extras_json, json.c_str(), json.size() + 1);
        }
    }
    return OBS_STATUS_OK;
}

/* Every node has at most one parent, children are in range, and following parents from any
 * node reaches a root (no cycle). Iterative, O(nodes + edges). */
obs_status Loader::check_node_graph()
{
    const size_t n = model_.nodes.size();
    std::vector<int> parent(n, -1);
    for (size_t i = 0; i < n; i++) {
        for (int c : model_.nodes[i].children) {
            if (c < 0 || static_cast<size_t>(c) >= n)
                return fail(OBS_STATUS_PARSE_ERROR, "node %zu: child index %d out of range (%zu nodes)", i, c, n);
            if (static_cast<size_t>(c) == i)
                return fail(OBS_STATUS_PARSE_ERROR, "cyclic node graph at node %zu (its own child)", i);
            if (parent[static_cast<size_t>(c)] != -1)
                return fail(OBS_STATUS_PARSE_ERROR,
                            "invalid node graph: node %d has more than one parent (nodes %d and %zu)", c,
                            parent[static_cast<size_t>(c)], i);
            parent[static_cast<size_t>(c)] = static_cast<int>(i);
        }
    }
    /* state: 0 unvisited, 1 on the current parent chain, 2 known to reach a root */
    std::vector<unsigned char> state(n, 0);
    std::vector<size_t> chain;
    for (size_t i = 0; i < n; i++) {
        if (state[i])
            continue;
        chain.clear();
        size_t k = i;
        for (;;) {
            if (state[k] == 2)
                break;
            if (state[k] == 1)
                return fail(OBS_STATUS_PARSE_ERROR, "cyclic node graph at node %zu", k);
            state[k] = 1;
            chain.push_back(k);
            if (parent[k] == -1)
                break;
            k = static_cast<size_t>(parent[k]);
        }
        for (size_t c : chain)
            state[c] = 2;
    }
    return OBS_STATUS_OK;
}

obs_status Loader::local_matrix(int ni, obs_mat4 *m)
{
    const tinygltf::Node &node = model_.nodes[static_cast<size_t>(ni)];
    if (!node.matrix.empty()) {
        if (node.matrix.size() != 16)
            return fail(OBS_STATUS_PARSE_ERROR, "node %d: matrix has %zu elements, not 16", ni, node.matrix.size());
        for (int k = 0; k < 16; k++)
            m->m[k] = static_cast<float>(node.matrix[static_cast<size_t>(k)]);
        return OBS_STATUS_OK;
    }
    obs_vec3 t = obs_v3(0, 0, 0), s = obs_v3(1, 1, 1);
    obs_vec4 q = {0, 0, 0, 1};
    if (!node.translation.empty()) {
        if (node.translation.size() != 3)
            return fail(OBS_STATUS_PARSE_ERROR, "node %d: translation has %zu elements, not 3", ni,
                        node.translation.size());
        t = obs_v3(static_cast<float>(node.translation[0]), static_cast<float>(node.translation[1]),
                   static_cast<float>(node.translation[2]));
    }
    if (!node.rotation.empty()) {
        if (node.rotation.size() != 4)
            return fail(OBS_STATUS_PARSE_ERROR, "node %d: rotation has %zu elements, not 4", ni, node.rotation.size());
        q.x = static_cast<float>(node.rotation[0]);
        q.y = static_cast<float>(node.rotation[1]);
        q.z = static_cast<float>(node.rotation[2]);
        q.w = static_cast<float>(node.rotation[3]);
    }
    if (!node.scale.empty()) {
        if (node.scale.size() != 3)
            return fail(OBS_STATUS_PARSE_ERROR, "node %d: scale has %zu elements, not 3", ni, node.scale.size());
        s = obs_v3(static_cast<float>(node.scale[0]), static_cast<float>(node.scale[1]),
                   static_cast<float>(node.scale[2]));
    }
    *m = obs_mat4_from_trs(t, q, s);
    return OBS_STATUS_OK;
}

/* The node's rotation and translation without scale: Gram-Schmidt on the columns, keeping the
 * node's -Z (view direction) first and +Y (up) second. Returns 0 when degenerate. */
int camera_frame(const obs_mat4 &w, obs_mat4 *out)
{
    obs_vec3 c1 = obs_v3(w.m[4], w.m[5], w.m[6]);
    obs_vec3 c2 = obs_v3(w.m[8], w.m[9], w.m[10]);
    obs_vec3 z = obs_v3_normalize(c2);
    if (obs_v3_dot(z, z) == 0.0f)
        return 0;
    obs_vec3 y = obs_v3_normalize(obs_v3_sub(c1, obs_v3_scale(z, obs_v3_dot(c1, z))));
    if (obs_v3_dot(y, y) == 0.0f)
        return 0;
    obs_vec3 x = obs_v3_cross(y, z);
    obs_mat4 r = obs_mat4_identity();
    r.m[0] = x.x; r.m[1] = x.y; r.m[2] = x.z;
    r.m[4] = y.x; r.m[5] = y.y; r.m[6] = y.z;
    r.m[8] = z.x; r.m[9] = z.y; r.m[10] = z.z;
    r.m[12] = w.m[12]; r.m[13] = w.m[13]; r.m[14] = w.m[14];
    *out = r;
    return obs_mat4_is_finite(r);
}

obs_status Loader::add_camera(int ni, const obs_mat4 &world)
{
    const tinygltf::Node &node = model_.nodes[static_cast<size_t>(ni)];
    const int ci = node.camera;
    if (ci < 0 || static_cast<size_t>(ci) >= model_.cameras.size())
        return fail(OBS_STATUS_PARSE_ERROR, "node %d: camera %d out of range (%zu cameras)", ni, ci,
                    model_.cameras.size());
    const tinygltf::Camera &src = model_.cameras[static_cast<size_t>(ci)];
    obs_camera cam;
    memset(&cam, 0, sizeof cam);
    copy_name(cam.name, src.name.empty() ? node.name : src.name);
    const std::string qn = quoted(src.name);
    const char *nm = qn.c_str();
    if (src.type == "perspective") {
        const tinygltf::PerspectiveCamera &p = src.perspective;
        cam.projection = OBS_PROJECTION_PERSPECTIVE;
        if (!(p.yfov > 0.0 && p.yfov < OBS_PI))
            return fail(OBS_STATUS_PARSE_ERROR, "camera %d%s (node %d): yfov %g is not in (0, pi)", ci, nm, ni, p.yfov);
        if (!(p.znear > 0.0) || !std::isfinite(p.znear))
            return fail(OBS_STATUS_PARSE_ERROR, "camera %d%s (node %d): znear %g is not > 0", ci, nm, ni, p.znear);
        /* tinygltf stores an absent zfar as 0 (infinite projection) */
        if (p.zfar != 0.0 && !(p.zfar > p.znear))
            return fail(OBS_STATUS_PARSE_ERROR, "camera %d%s (node %d): zfar %g is not > znear %g", ci, nm, ni,
                        p.zfar, p.znear);
        if (p.aspectRatio < 0.0 || !std::isfinite(p.aspectRatio))
            return fail(OBS_STATUS_PARSE_ERROR, "camera %d%s (node %d): aspectRatio %g is not > 0", ci, nm, ni,
                        p.aspectRatio);
        cam.yfov = static_cast<float>(p.yfov);
        cam.aspect = static_cast<float>(p.aspectRatio);
        cam.znear = static_cast<float>(p.znear);
        cam.zfar = p.zfar == 0.0 ? INFINITY : static_cast<float>(p.zfar);
        if (!(cam.zfar > cam.znear))
            return fail(OBS_STATUS_PARSE_ERROR, "camera %d%s (node %d): zfar %g and znear %g collapse in float", ci,
                        nm, ni, p.zfar, p.znear);
    } else if (src.type == "orthographic") {
        const tinygltf::OrthographicCamera &o = src.orthographic;
        cam.projection = OBS_PROJECTION_ORTHOGRAPHIC;
        if (!(o.xmag != 0.0 && std::isfinite(o.xmag)) || !(o.ymag != 0.0 && std::isfinite(o.ymag)))
            return fail(OBS_STATUS_PARSE_ERROR, "camera %d%s (node %d): xmag %g / ymag %g must be finite and non-zero",
                        ci, nm, ni, o.xmag, o.ymag);
        if (!(o.znear >= 0.0) || !std::isfinite(o.znear))
            return fail(OBS_STATUS_PARSE_ERROR, "camera %d%s (node %d): znear %g is not >= 0", ci, nm, ni, o.znear);
        if (!(o.zfar > o.znear) || !std::isfinite(o.zfar))
            return fail(OBS_STATUS_PARSE_ERROR, "camera %d%s (node %d): zfar %g is not > znear %g", ci, nm, ni,
                        o.zfar, o.znear);
        cam.xmag = static_cast<float>(o.xmag);
        cam.ymag = static_cast<float>(o.ymag);
        cam.znear = static_cast<float>(o.znear);
        cam.zfar = static_cast<float>(o.zfar);
    } else {
        return fail(OBS_STATUS_PARSE_ERROR, "camera %d%s (node %d): unknown type '%s'", ci, nm, ni, src.type.c_str());
    }
    obs_mat4 frame;
    if (!camera_frame(world, &frame) || !obs_camera_set_world(&cam, frame))
        return fail(OBS_STATUS_PARSE_ERROR, "camera %d%s (node %d): the node's world matrix is singular or not finite",
                    ci, nm, ni);
    cameras_.push_back(cam);
    return OBS_STATUS_OK;
}

obs_status Loader::add_light(int ni, int li, const obs_mat4 &world)
{
    const tinygltf::Node &node = model_.nodes[static_cast<size_t>(ni)];
    if (li < 0 || static_cast<size_t>(li) >= model_.lights.size())
        return fail(OBS_STATUS_PARSE_ERROR, "node %d: KHR_lights_punctual light %d out of range (%zu lights)", ni, li,
                    model_.lights.size());
    const tinygltf::Light &src = model_.lights[static_cast<size_t>(li)];
    const std::string qn = quoted(src.name);
    const char *nm = qn.c_str();
    obs_light l;
    memset(&l, 0, sizeof l);
    copy_name(l.name, src.name.empty() ? node.name : src.name);
    l.node = static_cast<uint32_t>(ni);
    if (src.type == "directional")
        l.type = OBS_LIGHT_DIRECTIONAL;
    else if (src.type == "point")
        l.type = OBS_LIGHT_POINT;
    else if (src.type == "spot")
        l.type = OBS_LIGHT_SPOT;
    else
        return fail(OBS_STATUS_PARSE_ERROR, "light %d%s (node %d): unknown type '%s'", li, nm, ni, src.type.c_str());
    l.color = obs_v3(1, 1, 1);
    if (!src.color.empty()) {
        if (src.color.size() != 3)
            return fail(OBS_STATUS_PARSE_ERROR, "light %d%s: color has %zu elements, not 3", li, nm, src.color.size());
        l.color = obs_v3(static_cast<float>(src.color[0]), static_cast<float>(src.color[1]),
                         static_cast<float>(src.color[2]));
    }
    l.intensity = static_cast<float>(src.intensity);
    l.range = static_cast<float>(src.range);
    if (!std::isfinite(l.intensity) || l.intensity < 0.0f || !std::isfinite(l.range) || l.range < 0.0f ||
        !std::isfinite(l.color.x) || !std::isfinite(l.color.y) || !std::isfinite(l.color.z))
        return fail(OBS_STATUS_PARSE_ERROR, "light %d%s: intensity %g, range %g or color not finite and >= 0", li, nm,
                    src.intensity, src.range);
    if (l.type == OBS_LIGHT_SPOT) {
        l.inner_cone = static_cast<float>(src.spot.innerConeAngle);
        l.outer_cone = static_cast<float>(src.spot.outerConeAngle);
        if (!(src.spot.innerConeAngle >= 0.0 && src.spot.innerConeAngle < src.spot.outerConeAngle &&
              src.spot.outerConeAngle <= OBS_PI / 2 + 1e-6))
            return fail(OBS_STATUS_PARSE_ERROR,
                        "light %d%s: spot cone angles inner %g, outer %g need 0 <= inner < outer <= pi/2", li, nm,
                        src.spot.innerConeAngle, src.spot.outerConeAngle);
    } else {
        l.inner_cone = 0.0f;
        l.outer_cone = OBS_PI_F / 4.0f;
    }
    if (!obs_mat4_is_finite(world))
        return fail(OBS_STATUS_PARSE_ERROR, "light %d%s (node %d): the node's world matrix is not finite", li, nm, ni);
    l.position = obs_mat4_mul_point(world, obs_v3(0, 0, 0));
    l.direction = obs_v3_normalize(obs_mat4_mul_dir(world, obs_v3(0, 0, -1)));
    if (obs_v3_dot(l.direction, l.direction) == 0.0f) {
        if (l.type != OBS_LIGHT_POINT)
            return fail(OBS_STATUS_PARSE_ERROR, "light %d%s (node %d): the node's world matrix collapses -Z", li, nm,
                        ni);
        l.direction = obs_v3(0, 0, -1);
    }
    lights_.push_back(l);
    return OBS_STATUS_OK;
}

obs_status Loader::walk()
{
    const size_t n = model_.nodes.size();
    std::vector<int> roots;
    if (!model_.scenes.empty()) {
        int si = opt_.scene_index;
        if (si < 0) {
            si = model_.defaultScene;
            if (si == -1)
                si = 0;
            if (si < 0 || static_cast<size_t>(si) >= model_.scenes.size())
                return fail(OBS_STATUS_PARSE_ERROR, "default scene %d out of range (%zu scenes)", si,
                            model_.scenes.size());
        } else if (static_cast<size_t>(si) >= model_.scenes.size()) {
            return fail(OBS_STATUS_NOT_FOUND, "scene %d requested, the file has %zu scenes", si, model_.scenes.size());
        }
        roots = model_.scenes[static_cast<size_t>(si)].nodes;
        const tinygltf::Value &sx = model_.scenes[static_cast<size_t>(si)].extras;
        if (sx.Type() != tinygltf::NULL_TYPE) {
            std::string json;
            if (!value_to_json(json, sx, 0))
                return fail(OBS_STATUS_PARSE_ERROR, "scene %d: extras nested deeper than %d levels", si, kMaxJsonDepth);
            out_->extras_json = static_cast<char *>(malloc(json.size() + 1));
            if (!out_->extras_json)
                return fail(OBS_STATUS_OUT_OF_MEMORY, "scene %d: cannot allocate the extras text", si);
            memcpy(out_->extras_json, json.c_str(), json.size() + 1);
        }
        std::vector<char> is_child(n, 0);
        for (size_t i = 0; i < n; i++)
            for (int c : model_.nodes[i].children)
                is_child[static_cast<size_t>(c)] = 1; /* ranges checked by check_node_graph */
        for (int r : roots) {
            if (r < 0 || static_cast<size_t>(r) >= n)
                return fail(OBS_STATUS_PARSE_ERROR, "scene %d: node %d out of range (%zu nodes)", si, r, n);
            if (is_child[static_cast<size_t>(r)])
                return fail(OBS_STATUS_PARSE_ERROR, "scene %d: node %d is listed as a root but has a parent", si, r);
        }
    } else {
        if (opt_.scene_index > 0)
            return fail(OBS_STATUS_NOT_FOUND, "scene %d requested, the file has no scenes", opt_.scene_index);
        std::vector<char> is_child(n, 0);
        for (size_t i = 0; i < n; i++)
            for (int c : model_.nodes[i].children)
                is_child[static_cast<size_t>(c)] = 1;
        for (size_t i = 0; i < n; i++)
            if (!is_child[i])
                roots.push_back(static_cast<int>(i));
    }

    std::vector<char> visited(n, 0);
    struct Item { int node; obs_mat4 parent; };
    std::vector<Item> stack;
    for (auto it = roots.rbegin(); it != roots.rend(); ++it)
        stack.push_back({*it, obs_mat4_identity()});
    while (!stack.empty()) {
        Item item = stack.back();
        stack.pop_back();
        const int ni = item.node;
        if (visited[static_cast<size_t>(ni)])
            return fail(OBS_STATUS_PARSE_ERROR, "node %d is reached twice from the scene roots", ni);
        visited[static_cast<size_t>(ni)] = 1;
        const tinygltf::Node &node = model_.nodes[static_cast<size_t>(ni)];
        obs_mat4 local;
        obs_status st = local_matrix(ni, &local);
        if (st != OBS_STATUS_OK)
            return st;
        obs_mat4 world = obs_mat4_mul(item.parent, local);
        if (node.mesh != -1) {
            if (node.mesh < 0 || static_cast<size_t>(node.mesh) >= model_.meshes.size())
                return fail(OBS_STATUS_PARSE_ERROR, "node %d: mesh %d out of range (%zu meshes)", ni, node.mesh,
                            model_.meshes.size());
            for (uint32_t m : mesh_map_[static_cast<size_t>(node.mesh)]) {
                obs_instance inst;
                inst.mesh = m;
                inst.node = static_cast<uint32_t>(ni);
                inst.world = world;
                instances_.push_back(inst);
            }
        }
        if (node.camera != -1) {
            st = add_camera(ni, world);
            if (st != OBS_STATUS_OK)
                return st;
        }
        auto ext = node.extensions.find("KHR_lights_punctual");
        if (ext != node.extensions.end()) {
            const tinygltf::Value &v = ext->second;
            if (!v.IsObject() || !v.Has("light") || !v.Get("light").IsNumber())
                return fail(OBS_STATUS_PARSE_ERROR, "node %d: KHR_lights_punctual without an integer 'light'", ni);
            const tinygltf::Value &lv = v.Get("light");
            double d = lv.GetNumberAsDouble();
            if (!(d >= 0.0 && d < 2147483647.0) || d != std::floor(d))
                return fail(OBS_STATUS_PARSE_ERROR, "node %d: KHR_lights_punctual light %g is not a valid index", ni, d);
            st = add_light(ni, static_cast<int>(d), world);
            if (st != OBS_STATUS_OK)
                return st;
        }
        for (auto it = node.children.rbegin(); it != node.children.rend(); ++it)
            stack.push_back({*it, world});
    }
    return OBS_STATUS_OK;
}

template <typename T>
bool copy_out(const std::vector<T> &v, T **dst, uint32_t *count)
{
    if (v.empty())
        return true;
    if (v.size() > UINT32_MAX)
        return false;
    *dst = static_cast<T *>(malloc(v.size() * sizeof(T)));
    if (!*dst)
        return false;
    memcpy(*dst, v.data(), v.size() * sizeof(T));
    *count = static_cast<uint32_t>(v.size());
    return true;
}

obs_status Loader::commit()
{
    if (!copy_out(instances_, &out_->instances, &out_->instance_count) ||
        !copy_out(cameras_, &out_->cameras, &out_->camera_count) ||
        !copy_out(lights_, &out_->lights, &out_->light_count))
        return fail(OBS_STATUS_OUT_OF_MEMORY, "cannot allocate instances, cameras or lights");
    return OBS_STATUS_OK;
}

/* glTF 2.0 spec 3.12: a loader MUST refuse a file whose extensionsRequired it does not support.
 * Extensions that only change textures or shading inputs obscura does not read are harmless. */
obs_status Loader::check_extensions()
{
    /* Preflight has refused these already; this is the check on what tinygltf parsed */
    for (const std::string &e : model_.extensionsRequired) {
        if (!extension_supported(e))
            return fail(OBS_STATUS_UNSUPPORTED, "requires the extension %s, which obscura does not support", e.c_str());
    }
    if (!model_.skins.empty())
        obs_log(ctx_, OBS_LOG_WARN, "%s: %zu skins ignored (meshes are loaded in their bind pose)", path_,
                model_.skins.size());
    for (const tinygltf::Mesh &m : model_.meshes)
        for (const tinygltf::Primitive &prim : m.primitives)
            if (!prim.targets.empty()) {
                obs_log(ctx_, OBS_LOG_WARN, "%s: morph targets ignored (base geometry is loaded)", path_);
                return OBS_STATUS_OK;
            }
    return OBS_STATUS_OK;
}

obs_status Loader::run()
{
    snprintf(out_->source, sizeof out_->source, "%s", path_);
    obs_status st;
    {
        std::vector<unsigned char> bytes;
        st = parse(bytes);
    } /* the file bytes are no longer needed: tinygltf copied the buffers */
    if (st != OBS_STATUS_OK)
        return st;
    if ((st = check_extensions()) != OBS_STATUS_OK)
        return st;
    for (const std::string &e : model_.extensionsUsed)
        quantization_ = quantization_ || e == "KHR_mesh_quantization";
    if ((st = check_node_graph()) != OBS_STATUS_OK)
        return st;
    if ((st = load_materials()) != OBS_STATUS_OK)
        return st;
    if ((st = load_meshes()) != OBS_STATUS_OK)
        return st;
    if ((st = walk()) != OBS_STATUS_OK)
        return st;
    if ((st = commit()) != OBS_STATUS_OK)
        return st;
    obs_scene_update_bounds(out_);
    return obs_scene_validate(ctx_, out_);
}

} // namespace

extern "C" io_gltf_options io_gltf_options_default(void)
{
    io_gltf_options o;
    o.scene_index = -1;
    o.require_triangles = 1;
    return o;
}

namespace {

obs_status load(obs_context *ctx, const char *path, const void *mem, size_t mem_len, const io_gltf_options *opt,
                obs_scene *out)
{
    io_gltf_options o = opt ? *opt : io_gltf_options_default();
    obs_status st;
    try {
        Loader loader(ctx, path, o, out, mem, mem_len);
        st = loader.run();
    } catch (const std::bad_alloc &) {
        st = obs_error(ctx, OBS_STATUS_OUT_OF_MEMORY, "%s: out of memory while loading glTF", path);
    } catch (const std::exception &e) {
        st = obs_error(ctx, OBS_STATUS_PARSE_ERROR, "%s: %s", path, e.what());
    } catch (...) {
        st = obs_error(ctx, OBS_STATUS_INTERNAL, "%s: unknown exception while loading glTF", path);
    }
    if (st != OBS_STATUS_OK)
        obs_scene_free(out);
    return st;
}

} // namespace

extern "C" obs_status io_gltf_load(obs_context *ctx, const char *path, const io_gltf_options *opt, obs_scene *out)
{
    if (out)
        obs_scene_init(out);
    if (!path || !out)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "io_gltf_load: %s is NULL", !path ? "path" : "out");
    return load(ctx, path, nullptr, 0, opt, out);
}

extern "C" obs_status io_gltf_load_memory(obs_context *ctx, const char *name, const void *data, size_t len,
                                          const io_gltf_options *opt, obs_scene *out)
{
    if (out)
        obs_scene_init(out);
    if (!out || (!data && len > 0))
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "io_gltf_load_memory: %s is NULL", !out ? "out" : "data");
    if (!name || !name[0])
        name = "<memory>";
    if (len == 0)
        return obs_error(ctx, OBS_STATUS_PARSE_ERROR, "%s: empty file", name);
    return load(ctx, name, data, len, opt, out);
}
