/* truth_scene.c: the Embree 3 scene that mirrors an obs_scene (meshes + instances).
 *
 * Layout (docs/truth.md, "The Embree scene"): by default every instance is FLATTENED, its mesh's
 * vertices taken to world space (in double, rounded once to float) into a triangle geometry of
 * its own in the one top-level scene, with geomID = the instance index and primID = the
 * triangle's index in its mesh. A mesh whose extra copies (all but the first) would push the
 * flattened memory over the limit (truth_scene_options.flat_limit_bytes) stays two-level: one
 * Embree scene for the mesh, one instance geometry per obs_instance, again with geomID = the
 * instance index. A hit maps back to (instance, primitive) the same way in both cases:
 * instance = instID[0] when Embree went through an instance, else geomID. */
#include "truth_internal.h" /* struct truth_scene */

#include <embree3/rtcore.h>
#include <math.h>
#include <pmmintrin.h>
#include <stdlib.h>
#include <string.h>
#include <xmmintrin.h>

void truth_thread_init(void)
{
    _MM_SET_FLUSH_ZERO_MODE(_MM_FLUSH_ZERO_ON);
    _MM_SET_DENORMALS_ZERO_MODE(_MM_DENORMALS_ZERO_ON);
}

static obs_status embree_error(obs_context *ctx, RTCDevice dev, const char *what)
{
    enum RTCError e = dev ? rtcGetDeviceError(dev) : rtcGetDeviceError(NULL);
    return obs_error(ctx, OBS_STATUS_INTERNAL, "Embree: %s failed (error %d)", what, (int)e);
}

truth_scene_options truth_scene_options_default(void)
{
    truth_scene_options o;
    memset(&o, 0, sizeof o);
    o.quality = TRUTH_BUILD_MEDIUM;
    o.layout = TRUTH_SCENE_AUTO;
    o.flat_limit_bytes = TRUTH_SCENE_FLAT_LIMIT_BYTES;
    return o;
}

const char *truth_scene_layout_name(truth_scene_layout l)
{
    static const char *const names[TRUTH_SCENE_LAYOUT_COUNT] = {"auto", "flat", "instanced"};
    return (unsigned)l < TRUTH_SCENE_LAYOUT_COUNT ? names[l] : "?";
}

int64_t truth_scene_mesh_bytes(const obs_mesh *m)
{
    return (int64_t)m->vertex_count * 16 + (int64_t)m->triangle_count * (12 + TRUTH_SCENE_BVH_BYTES_PER_TRIANGLE);
}

/* Fill an Embree triangle geometry's buffers from a mesh, its vertices mapped by `world` (NULL:
 * object space as given). World positions are computed in double and rounded once. A triangle
 * with a non-finite vertex (in the space written) becomes (i0, i0, i0): degenerate, never hit,
 * matching the rasterizer, which skips it; its non-finite vertices are zeroed (Embree rejects a
 * NaN vertex at build when it is referenced). */
static int fill_triangles(RTCGeometry g, const obs_mesh *mesh, const obs_mat4 *world)
{
    float *vb = (float *)rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, 4 * sizeof(float),
                                                 mesh->vertex_count ? mesh->vertex_count : 1);
    unsigned *ib = (unsigned *)rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3,
                                                       3 * sizeof(unsigned), mesh->triangle_count);
    if (!vb || (!ib && mesh->triangle_count))
        return 0;
    double M[16];
    if (world)
        for (int k = 0; k < 16; k++)
            M[k] = (double)world->m[k];
    for (uint32_t v = 0; v < mesh->vertex_count; v++) {
        const float *p = &mesh->positions[3 * (size_t)v];
        if (world) {
            /* column-major: world = M[0..2] x + M[4..6] y + M[8..10] z + M[12..14] */
            for (int c = 0; c < 3; c++)
                vb[4 * v + c] = (float)(M[c] * p[0] + M[4 + c] * p[1] + M[8 + c] * p[2] + M[12 + c]);
        } else {
            vb[4 * v] = p[0];
            vb[4 * v + 1] = p[1];
            vb[4 * v + 2] = p[2];
        }
        vb[4 * v + 3] = 0.0f;
    }
    if (!mesh->vertex_count)
        vb[0] = vb[1] = vb[2] = vb[3] = 0.0f;
    for (uint32_t t = 0; t < mesh->triangle_count; t++) {
        const uint32_t *ix = &mesh->indices[3 * (size_t)t];
        int finite = 1;
        for (int k = 0; k < 3; k++)
            for (int c = 0; c < 3; c++)
                finite &= isfinite(vb[4 * (size_t)ix[k] + c]) != 0;
        ib[3 * t] = ix[0];
        ib[3 * t + 1] = finite ? ix[1] : ix[0];
        ib[3 * t + 2] = finite ? ix[2] : ix[0];
        if (!finite)
            for (int k = 0; k < 3; k++) {
                float *q = &vb[4 * (size_t)ix[k]];
                if (!isfinite(q[0]) || !isfinite(q[1]) || !isfinite(q[2]))
                    q[0] = q[1] = q[2] = 0.0f;
            }
    }
    return 1;
}

obs_status truth_scene_create(obs_context *ctx, const obs_scene *sc, truth_build_quality quality, truth_scene **out)
{
    truth_scene_options o = truth_scene_options_default();
    o.quality = quality;
    return truth_scene_create_ex(ctx, sc, &o, out);
}

obs_status truth_scene_create_ex(obs_context *ctx, const obs_scene *sc, const truth_scene_options *opt,
                                 truth_scene **out)
{
    if (!out)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "truth_scene_create: NULL result");
    *out = NULL;
    if (!sc || !opt)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "truth_scene_create: NULL argument");
    if ((unsigned)opt->quality >= TRUTH_BUILD_COUNT)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "truth_scene_create: build quality %d out of range",
                         (int)opt->quality);
    if ((unsigned)opt->layout >= TRUTH_SCENE_LAYOUT_COUNT)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "truth_scene_create: layout %d out of range",
                         (int)opt->layout);
    if (opt->flat_limit_bytes < 0)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "truth_scene_create: flat limit %lld bytes must be >= 0",
                         (long long)opt->flat_limit_bytes);
    for (uint32_t i = 0; i < sc->instance_count; i++)
        if (sc->instances[i].mesh >= sc->mesh_count)
            return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "truth_scene_create: instance %u names mesh %u of %u",
                             i, sc->instances[i].mesh, sc->mesh_count);
    truth_scene *ts = (truth_scene *)calloc(1, sizeof *ts);
    if (!ts)
        return obs_error(ctx, OBS_STATUS_OUT_OF_MEMORY, "truth_scene_create: out of memory");
    ts->device = rtcNewDevice(NULL);
    if (!ts->device) {
        free(ts);
        return embree_error(ctx, NULL, "rtcNewDevice");
    }
    enum RTCBuildQuality q = opt->quality == TRUTH_BUILD_LOW    ? RTC_BUILD_QUALITY_LOW
                             : opt->quality == TRUTH_BUILD_HIGH ? RTC_BUILD_QUALITY_HIGH
                                                                : RTC_BUILD_QUALITY_MEDIUM;
    ts->quality = opt->quality;
    ts->scene_flags = RTC_SCENE_FLAG_NONE;
    ts->mesh_count = sc->mesh_count;
    ts->instance_count = sc->instance_count;
    ts->meshes = (RTCScene *)calloc(sc->mesh_count ? sc->mesh_count : 1, sizeof(RTCScene));
    ts->normal_world = (obs_mat4 *)calloc(sc->instance_count ? sc->instance_count : 1, sizeof(obs_mat4));
    ts->flat = (unsigned char *)calloc(sc->instance_count ? sc->instance_count : 1, 1);
    ts->ng_sign = (float *)calloc(sc->instance_count ? sc->instance_count : 1, sizeof(float));
    uint32_t *uses = (uint32_t *)calloc(sc->mesh_count ? sc->mesh_count : 1, sizeof(uint32_t));
    unsigned char *mesh_flat = (unsigned char *)calloc(sc->mesh_count ? sc->mesh_count : 1, 1);
    if (!ts->meshes || !ts->normal_world || !ts->flat || !ts->ng_sign || !uses || !mesh_flat) {
        free(uses);
        free(mesh_flat);
        truth_scene_destroy(ts);
        return obs_error(ctx, OBS_STATUS_OUT_OF_MEMORY, "truth_scene_create: out of memory");
    }
    /* Which meshes are flattened: all (FLAT), none (INSTANCED), or (AUTO) each mesh in order
     * while the extra copies' estimated bytes, (uses - 1) x truth_scene_mesh_bytes, summed over
     * the meshes flattened so far, stay within the limit; a mesh drawn once costs no extra. */
    for (uint32_t i = 0; i < sc->instance_count; i++)
        uses[sc->instances[i].mesh]++;
    int64_t extra = 0;
    for (uint32_t m = 0; m < sc->mesh_count; m++) {
        if (opt->layout == TRUTH_SCENE_FLAT) {
            mesh_flat[m] = 1;
            extra += uses[m] > 1 ? (int64_t)(uses[m] - 1) * truth_scene_mesh_bytes(&sc->meshes[m]) : 0;
        } else if (opt->layout == TRUTH_SCENE_AUTO) {
            int64_t e = uses[m] > 1 ? (int64_t)(uses[m] - 1) * truth_scene_mesh_bytes(&sc->meshes[m]) : 0;
            if (e <= opt->flat_limit_bytes - extra) {
                mesh_flat[m] = 1;
                extra += e;
            }
        }
    }
    ts->flat_extra_bytes = extra;
    free(uses);
    obs_status st = OBS_STATUS_OK;
    /* one Embree scene per mesh that some instance draws two-level */
    for (uint32_t i = 0; i < sc->instance_count && st == OBS_STATUS_OK; i++) {
        uint32_t m = sc->instances[i].mesh;
        if (mesh_flat[m] || ts->meshes[m])
            continue;
        RTCScene s = rtcNewScene(ts->device);
        rtcSetSceneFlags(s, ts->scene_flags);
        rtcSetSceneBuildQuality(s, q);
        RTCGeometry g = rtcNewGeometry(ts->device, RTC_GEOMETRY_TYPE_TRIANGLE);
        rtcSetGeometryBuildQuality(g, q);
        if (!fill_triangles(g, &sc->meshes[m], NULL)) {
            rtcReleaseGeometry(g);
            rtcReleaseScene(s);
            st = embree_error(ctx, ts->device, "rtcSetNewGeometryBuffer");
            break;
        }
        rtcCommitGeometry(g);
        rtcAttachGeometryByID(s, g, 0);
        rtcReleaseGeometry(g);
        rtcCommitScene(s);
        ts->meshes[m] = s;
    }
    if (st == OBS_STATUS_OK) {
        ts->top = rtcNewScene(ts->device);
        rtcSetSceneFlags(ts->top, ts->scene_flags);
        rtcSetSceneBuildQuality(ts->top, q);
    }
    for (uint32_t i = 0; i < sc->instance_count && st == OBS_STATUS_OK; i++) {
        const obs_instance *in = &sc->instances[i];
        if (!obs_mat4_normal_matrix(in->world, &ts->normal_world[i]))
            ts->normal_world[i] = obs_mat4_identity();
        /* Embree's Ng through an instance is the normal matrix (inverse transpose) times the
         * object-space Ng = (world e1 x world e2) / det: a flattened triangle's world-space Ng
         * times sign(det) has the same direction, so both layouts report the same ng. */
        const float *w = in->world.m;
        double det = (double)w[0] * ((double)w[5] * w[10] - (double)w[9] * w[6]) -
                     (double)w[4] * ((double)w[1] * w[10] - (double)w[9] * w[2]) +
                     (double)w[8] * ((double)w[1] * w[6] - (double)w[5] * w[2]);
        ts->ng_sign[i] = det < 0.0 ? -1.0f : 1.0f;
        RTCGeometry g;
        if (mesh_flat[in->mesh]) {
            g = rtcNewGeometry(ts->device, RTC_GEOMETRY_TYPE_TRIANGLE);
            rtcSetGeometryBuildQuality(g, q);
            if (!fill_triangles(g, &sc->meshes[in->mesh], &in->world)) {
                rtcReleaseGeometry(g);
                st = embree_error(ctx, ts->device, "rtcSetNewGeometryBuffer");
                break;
            }
            ts->flat[i] = 1;
            ts->triangles_flat += sc->meshes[in->mesh].triangle_count;
        } else {
            g = rtcNewGeometry(ts->device, RTC_GEOMETRY_TYPE_INSTANCE);
            rtcSetGeometryInstancedScene(g, ts->meshes[in->mesh]);
            rtcSetGeometryTransform(g, 0, RTC_FORMAT_FLOAT4X4_COLUMN_MAJOR, in->world.m);
            ts->instances_two_level++;
        }
        rtcCommitGeometry(g);
        rtcAttachGeometryByID(ts->top, g, i); /* geomID = the instance index, either way */
        rtcReleaseGeometry(g);
    }
    free(mesh_flat);
    if (st == OBS_STATUS_OK) {
        rtcCommitScene(ts->top);
        if (rtcGetDeviceError(ts->device) != RTC_ERROR_NONE)
            st = embree_error(ctx, ts->device, "scene build");
    }
    if (st != OBS_STATUS_OK) {
        truth_scene_destroy(ts);
        return st;
    }
    *out = ts;
    return OBS_STATUS_OK;
}

void truth_scene_get_info(const truth_scene *ts, truth_scene_info *info)
{
    memset(info, 0, sizeof *info);
    if (!ts)
        return;
    info->instances_flat = ts->instance_count - ts->instances_two_level;
    info->instances_two_level = ts->instances_two_level;
    info->triangles_flat = ts->triangles_flat;
    info->flat_extra_bytes = ts->flat_extra_bytes;
    info->quality = ts->quality;
    info->scene_flags = (unsigned)ts->scene_flags;
}

void truth_scene_destroy(truth_scene *ts)
{
    if (!ts)
        return;
    if (ts->top)
        rtcReleaseScene(ts->top);
    if (ts->meshes)
        for (uint32_t m = 0; m < ts->mesh_count; m++)
            if (ts->meshes[m])
                rtcReleaseScene(ts->meshes[m]);
    free(ts->meshes);
    free(ts->normal_world);
    free(ts->flat);
    free(ts->ng_sign);
    if (ts->device)
        rtcReleaseDevice(ts->device);
    free(ts);
}

void truth_intersect1(const truth_scene *ts, obs_vec3 o, obs_vec3 d, float tnear, float tfar, truth_hit *hit)
{
    struct RTCIntersectContext ictx;
    rtcInitIntersectContext(&ictx);
    struct RTCRayHit rh;
    memset(&rh, 0, sizeof rh);
    rh.ray.org_x = o.x; rh.ray.org_y = o.y; rh.ray.org_z = o.z;
    rh.ray.dir_x = d.x; rh.ray.dir_y = d.y; rh.ray.dir_z = d.z;
    rh.ray.tnear = tnear;
    rh.ray.tfar = tfar;
    rh.ray.mask = 0xFFFFFFFFu;
    rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
    rh.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
    rtcIntersect1(ts->top, &ictx, &rh);
    if (rh.hit.geomID == RTC_INVALID_GEOMETRY_ID) {
        hit->instance = hit->prim = 0xFFFFFFFFu;
        hit->t = INFINITY;
        hit->u = hit->v = 0.0f;
        hit->ng = obs_v3(0, 0, 0);
        return;
    }
    const int through_instance = rh.hit.instID[0] != RTC_INVALID_GEOMETRY_ID;
    hit->instance = through_instance ? rh.hit.instID[0] : rh.hit.geomID;
    hit->prim = rh.hit.primID;
    hit->t = rh.ray.tfar;
    hit->u = rh.hit.u;
    hit->v = rh.hit.v;
    obs_vec3 ng = obs_v3(rh.hit.Ng_x, rh.hit.Ng_y, rh.hit.Ng_z);
    if (through_instance) /* Embree 3 reports Ng in the instance's object space: take it to world space */
        ng = obs_mat4_mul_dir(ts->normal_world[hit->instance], ng);
    else /* a flattened triangle: world space already; the sign as through an instance (above) */
        ng = obs_v3_scale(ng, ts->ng_sign[hit->instance]);
    hit->ng = obs_v3_normalize(ng);
}
