#!/usr/bin/env python3
"""bench/vtk_peer.py: VTK 9.1's CPU ray caster (vtkFixedPointVolumeRayCastMapper) on the volume,
transfer function, camera, light and step that `obscura volume` uses, for the side-by-side
benchmark of issue 15 section 11 (bench/run.sh vtk; docs/volume/vtk-peer.md).

Run it with Debian's python3-vtk9 (the system python, /usr/bin/python3) under xvfb-run:

  xvfb-run -a /usr/bin/python3 bench/vtk_peer.py data/cache/volumes/cranium.nrrd \\
      --tf data/transfer/ct-skin.json --mode ea --size 1920x1080 --threads 2 \\
      --camera-from obscura_sidecar.json --reps 5 --out /tmp/vtk_ea

What matches obscura (src/cli/cmd_volume.c, docs/volume/raycast.md):
- the volume: the NRRD's samples (read here with numpy, attached raw only) into vtkImageData with
  the NRRD's spacing; origin 0 unless the header has a 'space origin' (obscura's loader likewise);
- the transfer function: the JSON's points as vtkColorTransferFunction (RGB space, clamped) and
  vtkPiecewiseFunction; the JSON's alpha is per ref_step (0 = one voxel of the smallest spacing),
  so SetScalarOpacityUnitDistance(ref_step): VTK corrects alpha as 1 - (1 - a)^(d / unit), the
  same as vol_tf_alpha_correct;
- the camera: obscura's framing (look along --camera-dir at the box's centre, vertical fov 40
  degrees, distance rad / sin(fov / 2) x 1.05), or exactly the sidecar's world matrix and znear/zfar
  with --camera-from;
- the step: SetSampleDistance(step), AutoAdjustSampleDistances off, LockSampleDistanceToInputSpacing
  off, ImageSampleDistance 1 (one ray per pixel); the default step is obscura's, half the smallest
  spacing;
- the light (phong): a directional scene light travelling along the sidecar's light direction (or
  obscura's default, the camera's upper right), white, intensity 1; ambient 0.2, diffuse 0.8,
  specular 0.8, power 32 (obscura's ka and e; see vtk-peer.md for what still differs).

Timing: after --warmup renders, --reps renders, each timed around renderWindow.Render() alone
(loading, table building in the warm-up and image read-back excluded). Prints one RESULT line:
  RESULT vtk mode=ea size=1920x1080 threads=2 reps=5 median_ms=... min_ms=... max_ms=...
and writes PREFIX.png (sRGB over black, like obscura's PNG) and PREFIX.pfm (linear RGB over black,
float, row 0 at the top in obscura's sense: `obscura compare` reads it through OpenImageIO).
--write-half OUT.nrrd writes the volume down-sampled by 2 on each axis (the mean of 2x2x2 blocks,
rounded, same type) and exits.
"""
import argparse
import json
import math
import os
import statistics
import sys
import time

import numpy as np

NRRD_TYPES = {"short": np.int16, "int16": np.int16, "signed short": np.int16, "ushort": np.uint16,
              "unsigned short": np.uint16, "uint16": np.uint16, "uchar": np.uint8, "unsigned char": np.uint8,
              "uint8": np.uint8, "float": np.float32}


def read_nrrd(path):
    """An attached, raw NRRD (what scripts/fetch_volumes.sh writes): (array z,y,x, spacing, origin, header)."""
    with open(path, "rb") as f:
        blob = f.read()
    end = blob.find(b"\n\n")
    if not blob.startswith(b"NRRD") or end < 0:
        sys.exit(f"vtk_peer: {path}: not an attached NRRD")
    hdr = {}
    for line in blob[:end].decode("latin-1").splitlines()[1:]:
        if line.startswith("#") or ":" not in line:
            continue
        k, v = line.split(":", 1)
        hdr[k.strip()] = v.strip().lstrip("=").strip()
    if hdr.get("encoding") != "raw" or int(hdr.get("dimension", 0)) != 3:
        sys.exit(f"vtk_peer: {path}: only 3D raw NRRD is read here")
    nx, ny, nz = (int(s) for s in hdr["sizes"].split())
    dt = np.dtype(NRRD_TYPES[hdr["type"]]).newbyteorder("<" if hdr.get("endian", "little") == "little" else ">")
    skip = int(hdr.get("byte skip", 0))
    data = np.frombuffer(blob, dtype=dt, count=nx * ny * nz, offset=end + 2 + skip).reshape(nz, ny, nx)
    if "spacings" in hdr:
        sp = [float(s) for s in hdr["spacings"].split()]
    elif "space directions" in hdr:
        vecs = [[float(c) for c in v.strip("() ").split(",")] for v in hdr["space directions"].split(")")[:3]]
        sp = [math.sqrt(sum(c * c for c in v)) for v in vecs]
    else:
        sp = [1.0, 1.0, 1.0]
    org = [0.0, 0.0, 0.0]
    if "space origin" in hdr:
        org = [float(c) for c in hdr["space origin"].strip("() ").split(",")]
    return np.ascontiguousarray(data.astype(dt.newbyteorder("="))), sp, org, hdr


def write_half(src, dst):
    a, sp, org, hdr = read_nrrd(src)
    nz, ny, nx = (s // 2 for s in a.shape)
    b = a[:2 * nz, :2 * ny, :2 * nx].astype(np.float64).reshape(nz, 2, ny, 2, nx, 2).mean(axis=(1, 3, 5))
    b = np.rint(b).astype(a.dtype)
    sp2 = [2 * s for s in sp]
    with open(dst + ".tmp", "wb") as f:
        f.write(("NRRD0004\n# %s down-sampled by 2 per axis (mean of 2x2x2 blocks, rounded) by bench/vtk_peer.py\n"
                 "type: %s\ndimension: 3\nsizes: %d %d %d\nspacings: %.9g %.9g %.9g\nendian: little\nencoding: raw\n\n"
                 % (os.path.basename(src), hdr["type"], nx, ny, nz, *sp2)).encode())
        f.write(b.astype(b.dtype.newbyteorder("<")).tobytes())
    os.replace(dst + ".tmp", dst)
    print(f"vtk_peer: wrote {dst} ({nx}x{ny}x{nz}, spacing {sp2})")


def load_tf(arg, here):
    path = arg if os.path.exists(arg) else os.path.join(here, "data", "transfer", arg + ".json")
    with open(path) as f:
        tf = json.load(f)
    return tf, path


def normalize(v):
    n = math.sqrt(sum(c * c for c in v))
    return [c / n for c in v]


def framing(dims, sp, org, cam_dir, W, H):
    """obscura's `volume` framing (src/cli/cmd_volume.c): eye, target, up, yfov (rad), znear, zfar."""
    lo = [org[a] - 0.5 * sp[a] for a in range(3)]
    hi = [org[a] + (dims[a] - 1) * sp[a] + 0.5 * sp[a] for a in range(3)]
    ctr = [0.5 * (lo[a] + hi[a]) for a in range(3)]
    rad = 0.5 * math.sqrt(sum((hi[a] - lo[a]) ** 2 for a in range(3)))
    cn = math.sqrt(sum(c * c for c in cam_dir))
    yfov = math.radians(40.0)
    dist = rad / math.sin(0.5 * yfov) * 1.05
    eye = [ctr[a] - cam_dir[a] / cn * dist for a in range(3)]
    up = [0, 0, 1] if abs(cam_dir[1] / cn) > 0.99 else [0, 1, 0]
    return eye, ctr, up, yfov, max(1e-3 * dist, dist - 1.2 * rad), dist + 1.2 * rad


def main():
    here = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("volume")
    ap.add_argument("--tf", default="ct-skin", help="a JSON file or a name in data/transfer")
    ap.add_argument("--mode", choices=["ea", "phong"], default="ea")
    ap.add_argument("--size", default="1920x1080")
    ap.add_argument("--step", type=float, default=0.0, help="world units; 0 = half the smallest spacing (obscura's)")
    ap.add_argument("--camera-dir", default="-0.3,-0.4,-1")
    ap.add_argument("--camera-from", help="an `obscura volume` sidecar: its camera and light, exactly")
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--warmup", type=int, default=1)
    ap.add_argument("--reps", type=int, default=5)
    ap.add_argument("--out", help="PREFIX for PREFIX.png and PREFIX.pfm")
    ap.add_argument("--write-half", metavar="OUT.nrrd")
    ap.add_argument("--obscura-bounds", action="store_true",
                    help="diagnosis, not for timing: pad the volume by one edge-replicated voxel per side and crop to "
                         "the voxel centres' hull plus half a voxel, obscura's box (vol_grid_bounds) instead of VTK's hull")
    args = ap.parse_args()
    if args.write_half:
        write_half(args.volume, args.write_half)
        return

    import vtk  # Debian python3-vtk9
    from vtk.util import numpy_support

    W, H = (int(s) for s in args.size.lower().split("x"))
    t0 = time.perf_counter()
    arr, sp, org, _ = read_nrrd(args.volume)
    if args.obscura_bounds:
        dims0 = arr.shape[::-1]
        arr = np.pad(arr, 1, mode="edge")  # clamp to edge, as vol_grid_sample
        org = [org[a] - sp[a] for a in range(3)]
    nz, ny, nx = arr.shape
    img = vtk.vtkImageData()
    img.SetDimensions(nx, ny, nz)
    img.SetSpacing(*sp)
    img.SetOrigin(*org)
    scal = numpy_support.numpy_to_vtk(arr.ravel(order="C"), deep=True)  # x fastest: VTK's point order
    scal.SetName("scalars")
    img.GetPointData().SetScalars(scal)
    t_load = time.perf_counter() - t0

    tf, tf_path = load_tf(args.tf, here)
    ref_step = float(tf.get("ref_step", 0.0)) or min(sp)  # docs/volume.md: 0 = one voxel of the smallest spacing
    step = args.step if args.step > 0 else 0.5 * min(sp)  # docs/volume/raycast.md: the default step
    ctf = vtk.vtkColorTransferFunction()
    ctf.SetColorSpaceToRGB()
    ctf.ClampingOn()
    otf = vtk.vtkPiecewiseFunction()
    otf.ClampingOn()
    for v, r, g, b, a in tf["points"]:
        ctf.AddRGBPoint(v, r, g, b)
        otf.AddPoint(v, a)
    prop = vtk.vtkVolumeProperty()
    prop.SetColor(ctf)
    prop.SetScalarOpacity(otf)
    prop.SetScalarOpacityUnitDistance(ref_step)
    prop.SetInterpolationTypeToLinear()
    prop.SetIndependentComponents(True)
    if args.mode == "phong":
        prop.ShadeOn()
        prop.SetAmbient(0.2)   # obscura's ka (vol_rc_params_default)
        prop.SetDiffuse(0.8)   # 1 - ka
        prop.SetSpecular(0.8)  # 1 - ka
        prop.SetSpecularPower(32.0)
    else:
        prop.ShadeOff()

    vtk.vtkMultiThreader.SetGlobalDefaultNumberOfThreads(args.threads)
    vtk.vtkMultiThreader.SetGlobalMaximumNumberOfThreads(args.threads)
    mapper = vtk.vtkFixedPointVolumeRayCastMapper()
    mapper.SetInputData(img)
    mapper.SetNumberOfThreads(args.threads)
    mapper.AutoAdjustSampleDistancesOff()
    mapper.LockSampleDistanceToInputSpacingOff()
    mapper.SetSampleDistance(step)
    mapper.SetInteractiveSampleDistance(step)
    mapper.SetImageSampleDistance(1.0)
    mapper.SetMinimumImageSampleDistance(1.0)
    mapper.SetMaximumImageSampleDistance(1.0)
    mapper.IntermixIntersectingGeometryOff()
    if args.obscura_bounds:
        planes = []
        for a in range(3):
            planes += [org[a] + 0.5 * sp[a], org[a] + (dims0[a] + 0.5) * sp[a]]
        mapper.CroppingOn()
        mapper.SetCroppingRegionPlanes(*planes)
        mapper.SetCroppingRegionFlagsToSubVolume()
    vol = vtk.vtkVolume()
    vol.SetMapper(mapper)
    vol.SetProperty(prop)

    ren = vtk.vtkRenderer()
    ren.SetBackground(0, 0, 0)
    ren.AddVolume(vol)
    win = vtk.vtkRenderWindow()
    win.SetOffScreenRendering(1)
    win.SetMultiSamples(0)
    win.SetSize(W, H)
    win.AddRenderer(ren)

    light_dir = None
    if args.camera_from:
        with open(args.camera_from) as f:
            side = json.load(f)
        c = side["camera"]
        m = c["world_matrix_column_major"]  # columns: right, up, back, eye
        eye = m[12:15]
        fwd = [-m[8], -m[9], -m[10]]
        up = m[4:7]
        dist = 0.5 * (c["znear"] + c["zfar"])
        tgt = [eye[a] + fwd[a] * dist for a in range(3)]
        yfov, zn, zf = c["yfov_rad"], c["znear"], c["zfar"]
        if side.get("light", {}).get("type") == "directional":
            light_dir = side["light"]["direction"]
    else:
        cam_dir = [float(s) for s in args.camera_dir.split(",")]
        if args.obscura_bounds:
            eye, tgt, up, yfov, zn, zf = framing(dims0, sp, [org[a] + sp[a] for a in range(3)], cam_dir, W, H)
        else:
            eye, tgt, up, yfov, zn, zf = framing((nx, ny, nz), sp, org, cam_dir, W, H)
    cam = ren.GetActiveCamera()
    cam.SetPosition(*eye)
    cam.SetFocalPoint(*tgt)
    cam.SetViewUp(*up)
    cam.SetViewAngle(math.degrees(yfov))  # vertical, as obscura's yfov
    cam.SetClippingRange(zn, zf)
    if light_dir is None:  # obscura's default: view-space normalize(0.35, 0.6, 0.72), travelling away from it
        f = normalize([tgt[a] - eye[a] for a in range(3)])
        u = normalize(up)
        r = normalize([f[1] * u[2] - f[2] * u[1], f[2] * u[0] - f[0] * u[2], f[0] * u[1] - f[1] * u[0]])
        u = [r[1] * f[2] - r[2] * f[1], r[2] * f[0] - r[0] * f[2], r[0] * f[1] - r[1] * f[0]]
        back = [-c for c in f]
        light_dir = normalize([-(r[a] * 0.35 + u[a] * 0.6 + back[a] * 0.72) for a in range(3)])
    ren.AutomaticLightCreationOff()
    ren.RemoveAllLights()
    light = vtk.vtkLight()
    light.SetLightTypeToSceneLight()
    light.PositionalOff()
    light.SetFocalPoint(*tgt)
    light.SetPosition(*[tgt[a] - light_dir[a] for a in range(3)])  # VTK: direction = focal point - position
    light.SetColor(1, 1, 1)
    light.SetIntensity(1.0)
    ren.AddLight(light)

    for _ in range(max(0, args.warmup)):
        win.Render()
    ms = []
    for _ in range(args.reps):
        t = time.perf_counter()
        win.Render()
        ms.append(1e3 * (time.perf_counter() - t))
    print(f"RESULT vtk mode={args.mode} size={W}x{H} threads={args.threads} reps={args.reps} volume={args.volume} "
          f"dims={nx}x{ny}x{nz} step={step:.7g} ref_step={ref_step:.7g} tf={os.path.basename(tf_path)} "
          f"median_ms={statistics.median(ms):.1f} min_ms={min(ms):.1f} max_ms={max(ms):.1f} load_ms={1e3 * t_load:.0f} "
          f"mapper_threads={mapper.GetNumberOfThreads()} mapper_time_to_draw_ms={1e3 * mapper.GetTimeToDraw():.1f}", flush=True)

    if args.out:
        w2i = vtk.vtkWindowToImageFilter()
        w2i.SetInput(win)
        w2i.SetInputBufferTypeToRGB()
        w2i.ReadFrontBufferOff()
        w2i.Update()
        out = w2i.GetOutput()
        px = numpy_support.vtk_to_numpy(out.GetPointData().GetScalars()).reshape(H, W, 3)
        lin = np.flipud(px).astype(np.float32) / 255.0  # VTK's row 0 is the bottom; ours the top
        # PFM: rows bottom to top, little-endian (negative scale)
        with open(args.out + ".pfm", "wb") as f:
            f.write(b"PF\n%d %d\n-1.0\n" % (W, H))
            f.write(np.flipud(lin).astype("<f4").tobytes())
        srgb = np.where(lin <= 0.0031308, 12.92 * lin, 1.055 * np.power(np.maximum(lin, 0.0031308), 1 / 2.4) - 0.055)
        q = np.clip(np.rint(srgb * 255.0), 0, 255).astype(np.uint8)
        pimg = vtk.vtkImageData()
        pimg.SetDimensions(W, H, 1)
        pa = numpy_support.numpy_to_vtk(np.flipud(q).reshape(-1, 3), deep=True)
        pimg.GetPointData().SetScalars(pa)
        wr = vtk.vtkPNGWriter()
        wr.SetFileName(args.out + ".png")
        wr.SetInputData(pimg)
        wr.Write()


if __name__ == "__main__":
    main()
