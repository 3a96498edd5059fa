#!/usr/bin/env python3
"""make_corpus.py BUILD_DIR: regenerate the committed seed corpora in tests/fuzz/corpus/.

Needs a normal build (BUILD_DIR/obscura and the generated scenes in BUILD_DIR/data). Each target
gets a few valid inputs and a few broken ones; every seed stays under 64 KB. The output is
deterministic for a given build (EXR files carry no time stamp), so rerunning it changes nothing
unless the writers change. Seeds the fuzzers found later can be added by hand with
`fuzz_<target> -merge=1 corpus/<target> NEW_DIR` (docs/reliability.md)."""
import base64
import json
import os
import shutil
import struct
import subprocess
import sys
import tempfile

HERE = os.path.dirname(os.path.abspath(__file__))
CORPUS = os.path.join(HERE, "corpus")
LIMIT = 64 * 1024


def put(target, name, data):
    if isinstance(data, str):
        data = data.encode()
    assert len(data) < LIMIT, (target, name, len(data))
    d = os.path.join(CORPUS, target)
    os.makedirs(d, exist_ok=True)
    with open(os.path.join(d, name), "wb") as f:
        f.write(data)


def glb(doc, bin_chunk=b""):
    js = json.dumps(doc, separators=(",", ":")).encode()
    js += b" " * (-len(js) % 4)
    out = struct.pack("<4sII", b"glTF", 2, 0)
    out += struct.pack("<II", len(js), 0x4E4F534A) + js
    if bin_chunk:
        bin_chunk += b"\0" * (-len(bin_chunk) % 4)
        out += struct.pack("<II", len(bin_chunk), 0x004E4942) + bin_chunk
    return out[:8] + struct.pack("<I", len(out)) + out[12:]


def tri_doc(uri, extra=None):
    doc = {
        "asset": {"version": "2.0"},
        "buffers": [{"uri": uri, "byteLength": 44}] if uri is not None else [{"byteLength": 44}],
        "bufferViews": [{"buffer": 0, "byteOffset": 0, "byteLength": 36},
                        {"buffer": 0, "byteOffset": 36, "byteLength": 6}],
        "accessors": [{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3",
                       "min": [0, 0, 0], "max": [1, 1, 0]},
                      {"bufferView": 1, "componentType": 5123, "count": 3, "type": "SCALAR"}],
        "meshes": [{"name": "tri", "primitives": [{"attributes": {"POSITION": 0}, "indices": 1, "material": 0}]}],
        "materials": [{"name": "m", "pbrMetallicRoughness": {"baseColorFactor": [1, 0, 0, 1]},
                       "extras": {"albedo": 0.5, "list": [1, "two", None, True]}}],
        "nodes": [{"name": "root", "children": [1, 2, 3], "translation": [0, 0, -3]},
                  {"mesh": 0, "rotation": [0, 0, 0.7071068, 0.7071068], "scale": [2, 2, 2]},
                  {"camera": 0, "matrix": [1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 5, 1]},
                  {"camera": 1, "extensions": {"KHR_lights_punctual": {"light": 0}}}],
        "cameras": [{"type": "perspective", "perspective": {"yfov": 0.8, "znear": 0.1, "zfar": 100, "aspectRatio": 1.5}},
                    {"type": "orthographic", "orthographic": {"xmag": 2, "ymag": 2, "znear": 0, "zfar": 10}}],
        "extensionsUsed": ["KHR_lights_punctual"],
        "extensions": {"KHR_lights_punctual": {"lights": [
            {"type": "spot", "color": [1, 1, 1], "intensity": 5, "spot": {"innerConeAngle": 0.2, "outerConeAngle": 0.6}}]}},
        "scenes": [{"nodes": [0]}],
        "scene": 0,
    }
    if extra:
        extra(doc)
    return doc


TRI_BIN = struct.pack("<9f", 0, 0, 0, 1, 0, 0, 0, 1, 0) + struct.pack("<4H", 0, 1, 2, 0)
DATA_URI = "data:application/octet-stream;base64," + base64.b64encode(TRI_BIN).decode()


def gltf_seeds(build):
    for name in ["plane.glb", "closed_box.glb", "corner2.glb", "cornell_box.glb"]:
        with open(os.path.join(build, "data", name), "rb") as f:
            data = f.read()
        put("gltf", name, data)
    with open(os.path.join(build, "data", "closed_box.glb"), "rb") as f:
        box = f.read()
    put("gltf", "broken_truncated_box.glb", box[: len(box) // 2])
    put("gltf", "triangle_data_uri.gltf", json.dumps(tri_doc(DATA_URI), indent=1))
    put("gltf", "triangle.glb", glb(tri_doc(None), TRI_BIN))

    def cyclic(d):
        d["nodes"][1]["children"] = [0]
    put("gltf", "broken_cyclic_nodes.gltf", json.dumps(tri_doc(DATA_URI, cyclic)))

    def out_of_range(d):
        d["accessors"][0]["count"] = 1000
    put("gltf", "broken_accessor_out_of_range.glb", glb(tri_doc(None, out_of_range), TRI_BIN))

    def absurd(d):
        d["accessors"][0]["count"] = 4000000000
        d["accessors"][0].pop("bufferView")
    put("gltf", "broken_absurd_count.gltf", json.dumps(tri_doc(DATA_URI, absurd)))

    def bad_index(d):
        d["accessors"][1]["byteOffset"] = 2
        d["accessors"][1]["count"] = 2
    put("gltf", "broken_index_count.gltf", json.dumps(tri_doc(DATA_URI, bad_index)))

    def lines(d):
        d["meshes"][0]["primitives"][0]["mode"] = 1
    put("gltf", "lines_mode.gltf", json.dumps(tri_doc(DATA_URI, lines)))

    def required(d):
        d["extensionsRequired"] = ["KHR_draco_mesh_compression"]
    put("gltf", "broken_required_extension.gltf", json.dumps(tri_doc(DATA_URI, required)))
    put("gltf", "broken_external_buffer.gltf", json.dumps(tri_doc("tri.bin")))
    put("gltf", "broken_deep_nesting.gltf", '{"asset":{"version":"2.0"},"extras":' + "[" * 600 + "]" * 600 + "}")
    put("gltf", "broken_not_json.gltf", "{\"asset\": {\"version\": \"2.0\"}, \"meshes\": [")


def run(cmd, cwd):
    subprocess.run(cmd, cwd=cwd, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)


def exr_seeds(build, tmp):
    cli = os.path.join(build, "obscura")
    plane = os.path.join(build, "data", "plane.glb")
    box = os.path.join(build, "data", "closed_box.glb")
    run([cli, "--threads", "1", "gbuffer", plane, "--size", "24x16", "-o", "g"], tmp)
    run([cli, "--threads", "1", "gbuffer", box, "--size", "16x16", "--depth", "reversed-z", "--infinite-far",
         "--outputs", "depth,ndc,prim", "-o", "r"], tmp)
    run([cli, "--threads", "1", "truth", "ao", box, "--size", "12x12", "--max-samples", "32", "--min-samples", "16",
         "-o", "t"], tmp)
    for src, dst in [("g.exr", "gbuffer_plane.exr"), ("r.exr", "gbuffer_reversed_z.exr"), ("t.exr", "truth_ao.exr"),
                     ("g_normal.png", "preview_normal.png"), ("t.png", "truth_ao.png")]:
        with open(os.path.join(tmp, src), "rb") as f:
            put("exr", dst, f.read())
    with open(os.path.join(tmp, "g.exr"), "rb") as f:
        g = f.read()
    put("exr", "broken_truncated.exr", g[: len(g) // 3])
    put("exr", "broken_header_only.exr", g[:64])
    with open(os.path.join(tmp, "g_normal.png"), "rb") as f:
        p = f.read()
    put("exr", "broken_truncated.png", p[: len(p) // 2])
    put("exr", "broken_garbage.bin", bytes(range(256)))


def gbuffer_seeds(build, tmp):
    """fuzz_gbuffer: byte 0 options, bytes 1-2 the JSON length, the JSON, then the image."""
    cli = os.path.join(build, "obscura")
    sp = os.path.join(build, "data", "sphere_on_plane.glb")
    run([cli, "--threads", "1", "gbuffer", sp, "--size", "24x16", "--guard", "3", "-o", "lin"], tmp)
    run([cli, "--threads", "1", "gbuffer", sp, "--size", "20x12", "--depth", "reversed-z", "--infinite-far",
         "--outputs", "depth,ndc", "-o", "rev"], tmp)
    run([cli, "--threads", "1", "gbuffer", sp, "--size", "17x9", "--depth", "gl", "--outputs", "ndc,normal",
         "-o", "gl"], tmp)

    def seed(name, opt, js, image):
        j = js.encode()
        put("gbuffer", name, bytes([opt, len(j) & 255, len(j) >> 8]) + j + image)

    imgs = {}
    for k in ("lin", "rev", "gl"):
        with open(os.path.join(tmp, k + ".exr"), "rb") as f:
            imgs[k] = f.read()
    flat = json.dumps({"fx": 20.5, "fy": 20.5, "cx": 12, "cy": 8, "projection": "perspective", "znear": 0.1,
                       "zfar": "infinity", "depth_kind": "reversed-z", "inner_window": [2, 2, 16, 10]})
    with open(os.path.join(tmp, "lin.json"), "rb") as f:
        sidecar = f.read().decode()
    seed("linear_metadata", 0, "", imgs["lin"])
    seed("linear_no_normals", 1 | (1 << 3), "", imgs["lin"])
    seed("linear_sidecar_json", 0x20, sidecar[:6000], imgs["lin"])
    seed("reversed_z_metadata", 0, "", imgs["rev"])
    seed("reversed_z_flat_json", 0x20 | 4, flat, imgs["rev"])
    seed("gl_ndc_metadata", 2, "", imgs["gl"])
    seed("broken_json_value", 0x20, '{"fx": "wide", "projection": 3}', imgs["gl"])
    seed("broken_image", 0, "", imgs["lin"][:200])


def off_seeds():
    put("off", "tetrahedron.off", "OFF\n4 4 6\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n3 0 2 1\n3 0 1 3\n3 0 3 2\n3 1 2 3\n")
    put("off", "quads_comments_colours.off",
        "# a cube with quads, comments and per-vertex colours\nOFF\n8 6 12\n"
        "-1 -1 -1 255 0 0\n1 -1 -1 0 255 0\n1 1 -1\n-1 1 -1\n-1 -1 1\n1 -1 1\n1 1 1 # top\n-1 1 1\n"
        "4 0 3 2 1\n4 4 5 6 7\n4 0 1 5 4\n4 2 3 7 6\n4 1 2 6 5\n4 0 4 7 3\n")
    put("off", "pentagon_fan_crlf.off", "OFF\r\n5 1 0\r\n0 0 0\r\n1 0 0\r\n1.5 1 0\r\n0.5 1.7 0\r\n-0.5 1 0\r\n5 0 1 2 3 4\r\n")
    put("off", "exponents_counts_on_header_line.off", "OFF 3 1 0\n1e-3 -2.5E+2 .5\n3 4 5 # c\n-0 0 1e10\n3 0 1 2 0.5 0.5 0.5\n")
    put("off", "broken_one_line.off", "OFF 3 1 0 1e-3 -2.5E+2 .5 3 4 5 -0 0 1e10 3 0 1 2\n")
    put("off", "broken_index_out_of_range.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 3\n")
    put("off", "broken_counts_too_large.off", "OFF\n2000000000 2000000000 0\n0 0 0\n")
    put("off", "broken_nan.off", "OFF\n3 1 0\n0 0 nan\n1 0 0\n0 1 0\n3 0 1 2\n")
    put("off", "broken_no_header.off", "3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n")
    put("off", "broken_face_size.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n99999999 0 1 2\n")
    put("off", "broken_truncated.off", "OFF\n4 2 0\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n3 0 1 2\n3 0")


def cli_seeds():
    seeds = {
        "gbuffer_small": ["gbuffer", "s.glb", "--size", "32x24", "-o", "out"],
        "gbuffer_options": ["gbuffer", "s.glb", "--camera", "top", "--size", "16x16", "--guard", "4", "--keep-guard",
                            "--depth", "reversed-z", "--infinite-far", "--cull", "back", "--isa", "scalar",
                            "--outputs", "depth,ndc,normal,prim", "-o", "g"],
        "gbuffer_limit": ["--max-pixels", "100", "gbuffer", "s.glb", "--size", "64x64"],
        "gbuffer_bad_size": ["gbuffer", "s.glb", "--size", "0x12"],
        "info_scene": ["info", "s.glb"],
        "info_exr": ["--verbose", "info", "a.exr"],
        "info_missing": ["info", "nothing.glb"],
        "compare": ["compare", "a.exr", "b.exr", "--json", "c.json", "--heatmap", "h.png", "--max-rmse", "0.1"],
        "compare_channels": ["compare", "a.exr", "b.exr", "--channel-a", "Z", "--channel-b", "AO.mean", "--mask",
                             "a.exr:primid", "--calibrated", "--ignore-nonfinite", "--min-ssim", "0.5"],
        "compare_png": ["compare", "p.png", "p.png", "--peak", "2", "--threshold", "0.01", "--quiet"],
        "truth": ["truth", "ao", "s.glb", "--size", "8x8", "--estimator", "obs-sao", "--radius", "0.5",
                  "--max-samples", "32", "--min-samples", "16", "--seed", "7", "-o", "t"],
        "truth_vol": ["truth", "ao", "s.glb", "--size", "6x6", "--estimator", "vol", "--origin", "embree",
                      "--normal", "shading", "--build", "low", "--tile", "4", "--batch", "8"],
        "ao_scene": ["ao", "--method", "sao", "--scene", "s.glb", "--size", "24x16", "--guard", "4", "-o", "o"],
        "ao_gbuffer": ["ao", "--method", "sao", "--gbuffer", "a.exr", "--intrinsics", "i.json", "--preset", "g3d",
                       "--samples", "5", "--max-mip", "2", "--no-blur", "-o", "o"],
        "ao_gbuffer_metadata": ["ao", "--method", "sao", "--gbuffer", "b.exr", "--depth-channel", "Z", "--depth-kind",
                                "linear", "--no-gbuffer-normals", "--radius", "0.3", "-o", "o"],
        "ao_list": ["ao", "--list"],
        "help": ["--help"],
        "version": ["--version"],
        "gbuffer_help": ["gbuffer", "--help"],
        "unknown": ["--threads", "x", "frobnicate"],
    }
    for name, args in seeds.items():
        put("cli_args", name, "\n".join(args) + "\n")


def json_seeds():
    def s(b):
        return bytes([len(b)]) + b

    # opcodes: low nibble = call (0 obj, 1 arr, 2 end obj, 3 end arr, 4 string, 5 double, 6 int,
    # 7 bool, 8 null, 9 floats, 10 raw, 11 special double); 0x80 = with a key (a string follows);
    # 0x40 = variant (null string, true).
    K = 0x80
    put("json", "object_of_everything",
        bytes([0]) + bytes([K | 4]) + s(b"name") + s(b"obscura \xc3\xa9\t\"q\"\\") +
        bytes([K | 5]) + s(b"pi") + struct.pack("<d", 3.141592653589793) +
        bytes([K | 6]) + s(b"big") + struct.pack("<q", -9223372036854775808) +
        bytes([K | 7 | 0x40]) + s(b"yes") + bytes([K | 8]) + s(b"none") +
        bytes([K | 9]) + s(b"m") + bytes([4]) + struct.pack("<4f", 1.0, -0.0, 1e-45, 3.4e38) +
        bytes([K | 10]) + s(b"raw") + bytes([7]) + bytes([K | 11]) + s(b"nan") + bytes([14]) + bytes([2]))
    put("json", "nested_arrays", bytes([1] * 10 + [3] * 10))
    put("json", "too_deep", bytes([1] * 70 + [3] * 70))
    put("json", "misuse_key_in_array", bytes([1, K | 6]) + s(b"k") + struct.pack("<q", 1) + bytes([3]))
    put("json", "invalid_utf8_string", bytes([1, 4]) + s(b"\xff\xfe latin-1 \xe9t\xe9 \xed\xa0\x80") + bytes([3]))
    put("json", "two_top_values", bytes([8, 8]))


def main():
    if len(sys.argv) != 2:
        sys.exit(__doc__)
    build = os.path.abspath(sys.argv[1])
    for t in ["gltf", "exr", "off", "cli_args", "json"]:
        shutil.rmtree(os.path.join(CORPUS, t), ignore_errors=True)
    tmp = tempfile.mkdtemp()
    try:
        gltf_seeds(build)
        exr_seeds(build, tmp)
        gbuffer_seeds(build, tmp)
        off_seeds()
        cli_seeds()
        json_seeds()
    finally:
        shutil.rmtree(tmp)
    total = 0
    for root, _, files in os.walk(CORPUS):
        for f in files:
            total += os.path.getsize(os.path.join(root, f))
    print(f"corpora: {total} bytes")


if __name__ == "__main__":
    main()
