/* truth_scene.c: the Embree 3 scene that mirrors an obs_scene (meshes + instances). */
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

obs_status truth_scene_create(obs_context *ctx, const obs_scene *sc, truth_build_quality quality, truth_scene **out)
{
    *out = NULL;
    truth_scene *ts = (truth_scene *)calloc(1, sizeof *ts);
    if (!ts)
        return obs_error(ctx, OBS_STATUS_OUT_OF_MEMORY, "truth_scene_create: out of memory");
    ts->device = rtcNewDevice(NULL);
    if (!ts->device) {
        free(ts);
        return embree_error(ctx, NULL, "rtcNewDevice");
    }
    enum RTCBuildQuality q = quality == TRUTH_BUILD_LOW ? RTC_BUILD_QUALITY_LOW
                             : quality == TRUTH_BUILD_HIGH ? RTC_BUILD_QUALITY_HIGH
                                                           : RTC_BUILD_QUALITY_MEDIUM;
    ts->mesh_count = sc->mesh_count;
    ts->instance_count = sc->instance_count;
    ts->meshes = (RTCScene *)calloc(sc->mesh_count ? sc->mesh_count : 1, sizeof(RTCScene));
    ts->normal_world = (obs_mat4 *)calloc(sc->instance_count ? sc->instance_count : 1, sizeof(obs_mat4));
    if (!ts->meshes || !ts->normal_world) {
        truth_scene_destroy(ts);
        return obs_error(ctx, OBS_STATUS_OUT_OF_MEMORY, "truth_scene_create: out of memory");
    }
    for (uint32_t m = 0; m < sc->mesh_count; m++) {
        const obs_mesh *mesh = &sc->meshes[m];
        RTCScene s = rtcNewScene(ts->device);
        rtcSetSceneBuildQuality(s, q);
        RTCGeometry g = rtcNewGeometry(ts->device, RTC_GEOMETRY_TYPE_TRIANGLE);
        rtcSetGeometryBuildQuality(g, q);
        float *vb = (float *)rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3,
                                                     4 * sizeof(float), mesh->vertex_count ? mesh->vertex_count : 1);
        unsigned *ib = (unsigned *)rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3,
                                                           3 * sizeof(unsigned), mesh->triangle_count);
        if (!vb || (!ib && mesh->triangle_count)) {
            rtcReleaseGeometry(g);
            rtcReleaseScene(s);
            obs_status st = embree_error(ctx, ts->device, "rtcSetNewGeometryBuffer");
            truth_scene_destroy(ts);
            return st;
        }
        for (uint32_t v = 0; v < mesh->vertex_count; v++) {
            vb[4 * v] = mesh->positions[3 * v];
            vb[4 * v + 1] = mesh->positions[3 * v + 1];
            vb[4 * v + 2] = mesh->positions[3 * v + 2];
            vb[4 * v + 3] = 0.0f;
        }
        if (!mesh->vertex_count)
            vb[0] = vb[1] = vb[2] = vb[3] = 0.0f;
        for (uint32_t t = 0; t < mesh->triangle_count; t++) {
            const uint32_t *ix = &mesh->indices[3 * (size_t)t];
            int finite = 1;
            for (int k = 0; k < 3; k++)
                for (int c = 0; c < 3; c++)
                    finite &= isfinite(mesh->positions[3 * (size_t)ix[k] + c]) != 0;
            /* A triangle with a non-finite vertex becomes (i0, i0, i0): degenerate, never hit,
             * matching the rasterizer, which skips it. */
            ib[3 * t] = ix[0];
            ib[3 * t + 1] = finite ? ix[1] : ix[0];
            ib[3 * t + 2] = finite ? ix[2] : ix[0];
            if (!finite) {
                /* Embree rejects NaN vertices at build only if referenced; also zero them. */
                for (int k = 0; k < 3; k++)
                    if (!isfinite(vb[4 * ix[k]]) || !isfinite(vb[4 * ix[k] + 1]) || !isfinite(vb[4 * ix[k] + 2]))
                        vb[4 * ix[k]] = vb[4 * ix[k] + 1] = vb[4 * ix[k] + 2] = 0.0f;
            }
        }
        rtcCommitGeometry(g);
        rtcAttachGeometryByID(s, g, 0);
        rtcReleaseGeometry(g);
        rtcCommitScene(s);
        ts->meshes[m] = s;
    }
    ts->top = rtcNewScene(ts->device);
    rtcSetSceneBuildQuality(ts->top, q);
    for (uint32_t i = 0; i < sc->instance_count; i++) {
        const obs_instance *in = &sc->instances[i];
        RTCGeometry g = rtcNewGeometry(ts->device, RTC_GEOMETRY_TYPE_INSTANCE);
        rtcSetGeometryInstancedScene(g, ts->meshes[in->mesh]);
        rtcSetGeometryTransform(g, 0, RTC_FORMAT_FLOAT4X4_COLUMN_MAJOR, in->world.m);
        rtcCommitGeometry(g);
        rtcAttachGeometryByID(ts->top, g, i);
        rtcReleaseGeometry(g);
        if (!obs_mat4_normal_matrix(in->world, &ts->normal_world[i]))
            ts->normal_world[i] = obs_mat4_identity();
    }
    rtcCommitScene(ts->top);
    if (rtcGetDeviceError(ts->device) != RTC_ERROR_NONE) {
        obs_status st = embree_error(ctx, ts->device, "scene build");
        truth_scene_destroy(ts);
        return st;
    }
    *out = ts;
    return OBS_STATUS_OK;
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
    hit->instance = rh.hit.instID[0];
    hit->prim = rh.hit.primID;
    hit->t = rh.ray.tfar;
    hit->u = rh.hit.u;
    hit->v = rh.hit.v;
    /* Embree 3 reports Ng in the instance's object space: take it to world space. */
    obs_vec3 ng = obs_v3(rh.hit.Ng_x, rh.hit.Ng_y, rh.hit.Ng_z);
    hit->ng = obs_v3_normalize(obs_mat4_mul_dir(ts->normal_world[hit->instance], ng));
}
