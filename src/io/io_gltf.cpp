/* io_gltf.cpp: glTF 2.0 loader (.gltf with external or data-URI buffers, and .glb), a thin C++17
 * adapter over tinygltf 2.7 behind the C API of io.h.
 *
 * tinygltf parses the JSON and loads buffers, but it checks neither accessor nor bufferView
 * ranges (build-notes.md), and its GLB reader trusts the BIN chunk length by 8 bytes too many.
 * So this file
 *   - reads the file itself, checks the GLB container strictly and the JSON nesting depth
 *     (tinygltf converts "extras" recursively) before handing the bytes to tinygltf;
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

#include <cerrno>
#include <cmath>
#include <cstdarg>
#include <cstdio>
#include <cstdlib>
#include <cstring>
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

/* ---- the loader ------------------------------------------------------------------------------ */

struct AccessorView {
    const unsigned char *base = nullptr; /* NULL: no bufferView, all zeros */
    uint64_t stride = 0;
    uint64_t count = 0;
    int component_type = 0;
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
    std::vector<std::vector<uint32_t>> mesh_map_; /* glTF mesh -> obs mesh indices */
    std::vector<obs_instance> instances_;
    std::vector<obs_camera> cameras_;
    std::vector<obs_light> lights_;
};

enum { KIND_VEC3F = 0, KIND_INDEX = 1 };

obs_status Loader::fail(obs_status st, const char *fmt, ...)
{
    char msg[900];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(msg, sizeof msg, fmt, ap);
    va_end(ap);
    return obs_error(ctx_, st, "%s: %s", path_, msg);
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
        ok = gltf.LoadBinaryFromMemory(&model_, &err, &warn, bytes.data(), len, fs_.base);
    } else {
        if (!json_depth_ok(bytes.data(), bytes.size(), kMaxJsonDepth))
            return fail(OBS_STATUS_PARSE_ERROR, "JSON nested deeper than %d levels", kMaxJsonDepth);
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
    if (kind == KIND_VEC3F) {
        if (a.componentType != TINYGLTF_COMPONENT_TYPE_FLOAT || a.type != TINYGLTF_TYPE_VEC3 || a.normalized)
            return fail(OBS_STATUS_PARSE_ERROR, "accessor %d (%s): wrong component type %s %s%s, expected FLOAT VEC3",
                        index, what.c_str(), component_name(a.componentType), type_name(a.type),
                        a.normalized ? " normalized" : "");
        elem = 12;
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

void read_vec3f(const AccessorView &v, float *dst)
{
    if (!v.base) {
        memset(dst, 0, static_cast<size_t>(v.count) * 12);
        return;
    }
    for (uint64_t i = 0; i < v.count; i++)
        memcpy(dst + 3 * i, v.base + i * v.stride, 12);
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
    obs_status st = accessor(pos_it->second, "POSITION of " + desc, KIND_VEC3F, &pos);
    if (st != OBS_STATUS_OK)
        return st;
    auto nrm_it = prim.attributes.find("NORMAL");
    bool has_normals = nrm_it != prim.attributes.end();
    if (has_normals) {
        st = accessor(nrm_it->second, "NORMAL of " + desc, KIND_VEC3F, &nrm);
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
    static const char *const harmless_prefixes[] = {"KHR_materials_", "KHR_texture_", "EXT_texture_"};
    for (const std::string &e : model_.extensionsRequired) {
        bool ok = e == "KHR_lights_punctual";
        for (const char *pre : harmless_prefixes)
            ok = ok || e.compare(0, strlen(pre), pre) == 0;
        if (!ok)
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
