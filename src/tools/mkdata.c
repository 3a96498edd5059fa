/* mkdata.c: the scene generator. `obscura_mkdata --out DIR --meshes CACHE` writes every bundled
 * scene as .glb, deterministically (the same bytes on every run). docs/data.md describes them.
 *
 * Units are metres, +Y up, glTF conventions. Faces are counter-clockwise seen from outside
 * (from inside for rooms and the closed box). Continuous surfaces (grids, spheres) share
 * vertices; hard edges (boxes, roofs) get per-face vertices with flat normals. */
#include "core/obs.h"
#include "io/io.h"
#include "off.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

/* ------------------------------------------------------------------------------------------------
 * Mesh builder
 * ---------------------------------------------------------------------------------------------- */

typedef struct mb {
    float *pos, *nrm;
    uint32_t *idx;
    uint32_t nv, nt, cv, ct;
} mb;

static void die(const char *msg)
{
    fprintf(stderr, "obscura_mkdata: %s\n", msg);
    exit(1);
}

static uint32_t mb_vertex(mb *m, obs_vec3 p, obs_vec3 n)
{
    if (m->nv == m->cv) {
        m->cv = m->cv ? 2 * m->cv : 256;
        m->pos = (float *)realloc(m->pos, sizeof(float) * 3 * m->cv);
        m->nrm = (float *)realloc(m->nrm, sizeof(float) * 3 * m->cv);
        if (!m->pos || !m->nrm)
            die("out of memory");
    }
    float *P = m->pos + 3 * m->nv, *N = m->nrm + 3 * m->nv;
    P[0] = p.x; P[1] = p.y; P[2] = p.z;
    N[0] = n.x; N[1] = n.y; N[2] = n.z;
    return m->nv++;
}

static void mb_tri(mb *m, uint32_t a, uint32_t b, uint32_t c)
{
    if (m->nt == m->ct) {
        m->ct = m->ct ? 2 * m->ct : 256;
        m->idx = (uint32_t *)realloc(m->idx, sizeof(uint32_t) * 3 * m->ct);
        if (!m->idx)
            die("out of memory");
    }
    m->idx[3 * m->nt] = a;
    m->idx[3 * m->nt + 1] = b;
    m->idx[3 * m->nt + 2] = c;
    m->nt++;
}

static obs_vec3 v3add3(obs_vec3 a, obs_vec3 b, obs_vec3 c) { return obs_v3_add(obs_v3_add(a, b), c); }

/* A grid of nu x nv quads on origin + s*u + t*v (s, t in [0,1]) with shared vertices, facing
 * n = normalize(u x v) (counter-clockwise seen from the n side). */
static void mb_grid(mb *m, obs_vec3 origin, obs_vec3 u, obs_vec3 v, int nu, int nv)
{
    obs_vec3 n = obs_v3_normalize(obs_v3_cross(u, v));
    uint32_t base = m->nv;
    for (int j = 0; j <= nv; j++)
        for (int i = 0; i <= nu; i++)
            mb_vertex(m, v3add3(origin, obs_v3_scale(u, (float)i / nu), obs_v3_scale(v, (float)j / nv)), n);
    for (int j = 0; j < nv; j++)
        for (int i = 0; i < nu; i++) {
            uint32_t a = base + (uint32_t)(j * (nu + 1) + i), b = a + 1, c = a + (uint32_t)(nu + 1), d = c + 1;
            mb_tri(m, a, b, d);
            mb_tri(m, a, d, c);
        }
}

/* An axis-aligned box [lo, hi] with flat faces; inward = faces seen from inside. */
static void mb_box(mb *m, obs_vec3 lo, obs_vec3 hi, int inward)
{
    obs_vec3 c = obs_v3_scale(obs_v3_add(lo, hi), 0.5f), h = obs_v3_scale(obs_v3_sub(hi, lo), 0.5f);
    /* normal, u, v with u x v = normal */
    static const float F[6][9] = {
        {1, 0, 0, 0, 1, 0, 0, 0, 1},   {-1, 0, 0, 0, 0, 1, 0, 1, 0}, {0, 1, 0, 0, 0, 1, 1, 0, 0},
        {0, -1, 0, 1, 0, 0, 0, 0, 1},  {0, 0, 1, 1, 0, 0, 0, 1, 0},  {0, 0, -1, 0, 1, 0, 1, 0, 0}};
    for (int f = 0; f < 6; f++) {
        obs_vec3 n = obs_v3(F[f][0], F[f][1], F[f][2]), u = obs_v3(F[f][3], F[f][4], F[f][5]),
                 v = obs_v3(F[f][6], F[f][7], F[f][8]);
        float hn = fabsf(obs_v3_dot(n, h)), hu = fabsf(obs_v3_dot(u, h)), hv = fabsf(obs_v3_dot(v, h));
        obs_vec3 fc = obs_v3_add(c, obs_v3_scale(n, hn));
        obs_vec3 p[4] = {v3add3(fc, obs_v3_scale(u, -hu), obs_v3_scale(v, -hv)),
                         v3add3(fc, obs_v3_scale(u, hu), obs_v3_scale(v, -hv)),
                         v3add3(fc, obs_v3_scale(u, hu), obs_v3_scale(v, hv)),
                         v3add3(fc, obs_v3_scale(u, -hu), obs_v3_scale(v, hv))};
        obs_vec3 nn = inward ? obs_v3_scale(n, -1.0f) : n;
        uint32_t i0 = mb_vertex(m, p[0], nn), i1 = mb_vertex(m, p[1], nn), i2 = mb_vertex(m, p[2], nn),
                 i3 = mb_vertex(m, p[3], nn);
        if (inward) {
            mb_tri(m, i0, i2, i1);
            mb_tri(m, i0, i3, i2);
        } else {
            mb_tri(m, i0, i1, i2);
            mb_tri(m, i0, i2, i3);
        }
    }
}

/* A flat triangle or quad (counter-clockwise as given), with its face normal. */
static void mb_poly(mb *m, const obs_vec3 *p, int n)
{
    obs_vec3 nn = obs_v3_normalize(obs_v3_cross(obs_v3_sub(p[1], p[0]), obs_v3_sub(p[2], p[0])));
    uint32_t i0 = mb_vertex(m, p[0], nn), prev = mb_vertex(m, p[1], nn);
    for (int k = 2; k < n; k++) {
        uint32_t cur = mb_vertex(m, p[k], nn);
        mb_tri(m, i0, prev, cur);
        prev = cur;
    }
}

/* A UV sphere with smooth normals, counter-clockwise outside. */
static void mb_sphere(mb *m, obs_vec3 c, float r, int slices, int stacks)
{
    uint32_t base = m->nv;
    for (int j = 0; j <= stacks; j++)
        for (int i = 0; i <= slices; i++) {
            double th = OBS_PI * j / stacks, ph = 2.0 * OBS_PI * (i % slices) / slices;
            obs_vec3 n = obs_v3((float)(sin(th) * cos(ph)), (float)cos(th), (float)(-sin(th) * sin(ph)));
            mb_vertex(m, obs_v3_add(c, obs_v3_scale(n, r)), n);
        }
    for (int j = 0; j < stacks; j++)
        for (int i = 0; i < slices; i++) {
            uint32_t a = base + (uint32_t)(j * (slices + 1) + i), b = a + 1, cc = a + (uint32_t)(slices + 1), d = cc + 1;
            if (j > 0)
                mb_tri(m, a, cc, b);
            if (j < stacks - 1)
                mb_tri(m, b, cc, d);
        }
}

/* A vertex welded by exact position (a linear search from `first`: small meshes only), so that a
 * closed surface built face by face is closed in its indices too (the SSS random walk checks it). */
static uint32_t mb_vertex_weld(mb *m, uint32_t first, obs_vec3 p, obs_vec3 n)
{
    for (uint32_t v = first; v < m->nv; v++)
        if (m->pos[3 * v] == p.x && m->pos[3 * v + 1] == p.y && m->pos[3 * v + 2] == p.z)
            return v;
    return mb_vertex(m, p, n);
}

static void mb_ico_face(mb *m, uint32_t base, obs_vec3 c, float r, obs_vec3 a, obs_vec3 b, obs_vec3 d, int level)
{
    if (level == 0) {
        uint32_t ia = mb_vertex_weld(m, base, obs_v3_add(c, obs_v3_scale(a, r)), a);
        uint32_t ib = mb_vertex_weld(m, base, obs_v3_add(c, obs_v3_scale(b, r)), b);
        uint32_t id = mb_vertex_weld(m, base, obs_v3_add(c, obs_v3_scale(d, r)), d);
        mb_tri(m, ia, ib, id);
        return;
    }
    /* Midpoints: (a + b) is commutative in IEEE arithmetic, so a shared edge gives the same point
     * from both of its faces. */
    obs_vec3 ab = obs_v3_normalize(obs_v3_add(a, b)), bd = obs_v3_normalize(obs_v3_add(b, d)),
             da = obs_v3_normalize(obs_v3_add(d, a));
    mb_ico_face(m, base, c, r, a, ab, da, level - 1);
    mb_ico_face(m, base, c, r, ab, b, bd, level - 1);
    mb_ico_face(m, base, c, r, da, bd, d, level - 1);
    mb_ico_face(m, base, c, r, ab, bd, da, level - 1);
}

/* A geodesic sphere: the icosahedron subdivided `level` times (20 * 4^level triangles), closed,
 * counter-clockwise outside, smooth normals. */
static void mb_icosphere(mb *m, obs_vec3 c, float r, int level)
{
    const float t = (float)((1.0 + sqrt(5.0)) / 2.0);
    obs_vec3 v[12] = {obs_v3(-1, t, 0), obs_v3(1, t, 0), obs_v3(-1, -t, 0), obs_v3(1, -t, 0),
                      obs_v3(0, -1, t), obs_v3(0, 1, t), obs_v3(0, -1, -t), obs_v3(0, 1, -t),
                      obs_v3(t, 0, -1), obs_v3(t, 0, 1), obs_v3(-t, 0, -1), obs_v3(-t, 0, 1)};
    static const int f[20][3] = {{0, 11, 5}, {0, 5, 1},  {0, 1, 7},   {0, 7, 10}, {0, 10, 11},
                                 {1, 5, 9},  {5, 11, 4}, {11, 10, 2}, {10, 7, 6}, {7, 1, 8},
                                 {3, 9, 4},  {3, 4, 2},  {3, 2, 6},   {3, 6, 8},  {3, 8, 9},
                                 {4, 9, 5},  {2, 4, 11}, {6, 2, 10},  {8, 6, 7},  {9, 8, 1}};
    for (int k = 0; k < 12; k++)
        v[k] = obs_v3_normalize(v[k]);
    uint32_t base = m->nv;
    for (int k = 0; k < 20; k++)
        mb_ico_face(m, base, c, r, v[f[k][0]], v[f[k][1]], v[f[k][2]], level);
}

/* ------------------------------------------------------------------------------------------------
 * Scene builder
 * ---------------------------------------------------------------------------------------------- */

static obs_scene g_scene;

static void sb_reset(void)
{
    obs_scene_free(&g_scene);
    obs_scene_init(&g_scene);
}

static void *grow_array(void *p, uint32_t count, size_t elem)
{
    void *q = realloc(p, (count + 1) * elem);
    if (!q)
        die("out of memory");
    memset((char *)q + count * elem, 0, elem);
    return q;
}

static int32_t sb_material(const char *name, float r, float g, float b)
{
    obs_scene *s = &g_scene;
    s->materials = (obs_material *)grow_array(s->materials, s->material_count, sizeof(obs_material));
    obs_material *m = &s->materials[s->material_count];
    snprintf(m->name, sizeof m->name, "%s", name);
    m->base_color[0] = r;
    m->base_color[1] = g;
    m->base_color[2] = b;
    m->base_color[3] = 1.0f;
    m->metallic = 0.0f;
    m->roughness = 1.0f;
    return (int32_t)s->material_count++;
}

/* Takes the builder's arrays. */
static uint32_t sb_mesh(const char *name, mb *b, int32_t material)
{
    obs_scene *s = &g_scene;
    s->meshes = (obs_mesh *)grow_array(s->meshes, s->mesh_count, sizeof(obs_mesh));
    obs_mesh *m = &s->meshes[s->mesh_count];
    snprintf(m->name, sizeof m->name, "%s", name);
    m->vertex_count = b->nv;
    m->triangle_count = b->nt;
    m->positions = b->pos;
    m->normals = b->nrm;
    m->indices = b->idx;
    m->material = material;
    memset(b, 0, sizeof *b);
    return s->mesh_count++;
}

static void sb_instance(uint32_t mesh, obs_mat4 world)
{
    obs_scene *s = &g_scene;
    s->instances = (obs_instance *)grow_array(s->instances, s->instance_count, sizeof(obs_instance));
    s->instances[s->instance_count].mesh = mesh;
    s->instances[s->instance_count].node = s->instance_count;
    s->instances[s->instance_count].world = world;
    s->instance_count++;
}

static void sb_camera(const char *name, obs_vec3 eye, obs_vec3 target, float yfov_deg, float znear, float zfar)
{
    obs_scene *s = &g_scene;
    s->cameras = (obs_camera *)grow_array(s->cameras, s->camera_count, sizeof(obs_camera));
    obs_camera c = obs_camera_look_at(eye, target, obs_v3(0, 1, 0), (float)(yfov_deg * OBS_PI / 180.0), znear, zfar);
    snprintf(c.name, sizeof c.name, "%s", name);
    s->cameras[s->camera_count++] = c;
}

static void sb_point_light(const char *name, obs_vec3 p, float intensity)
{
    obs_scene *s = &g_scene;
    s->lights = (obs_light *)grow_array(s->lights, s->light_count, sizeof(obs_light));
    obs_light *l = &s->lights[s->light_count++];
    snprintf(l->name, sizeof l->name, "%s", name);
    l->type = OBS_LIGHT_POINT;
    l->color = obs_v3(1, 1, 1);
    l->intensity = intensity;
    l->position = p;
    l->direction = obs_v3(0, -1, 0);
    l->outer_cone = (float)(OBS_PI / 4);
}

/* A directional light travelling along `dir` (normalised here), irradiance `lux`. */
static void sb_dir_light(const char *name, obs_vec3 dir, float lux)
{
    obs_scene *s = &g_scene;
    s->lights = (obs_light *)grow_array(s->lights, s->light_count, sizeof(obs_light));
    obs_light *l = &s->lights[s->light_count++];
    snprintf(l->name, sizeof l->name, "%s", name);
    l->type = OBS_LIGHT_DIRECTIONAL;
    l->color = obs_v3(1, 1, 1);
    l->intensity = lux;
    l->direction = obs_v3_normalize(dir);
    l->outer_cone = (float)(OBS_PI / 4);
}

/* A translucent material: its glTF extras carry the SSS schema (docs/sss.md, "Materials in glTF"). */
static int32_t sb_sss_material(const char *name, const char *preset)
{
    int32_t id = sb_material(name, 0.9f, 0.9f, 0.9f);
    char buf[128];
    snprintf(buf, sizeof buf, "{\"obscura_sss\":{\"preset\":\"%s\"}}", preset);
    size_t n = strlen(buf) + 1;
    g_scene.materials[id].extras_json = (char *)malloc(n);
    if (!g_scene.materials[id].extras_json)
        die("out of memory");
    memcpy(g_scene.materials[id].extras_json, buf, n);
    return id;
}

static int g_failed;
static void sb_write(obs_context *ctx, const char *dir, const char *file)
{
    char path[4096];
    snprintf(path, sizeof path, "%s/%s", dir, file);
    obs_scene_update_bounds(&g_scene);
    obs_status st = obs_scene_validate(ctx, &g_scene);
    if (st == OBS_STATUS_OK)
        st = io_glb_write(ctx, path, &g_scene);
    if (st != OBS_STATUS_OK) {
        fprintf(stderr, "obscura_mkdata: %s: %s\n", file, obs_context_last_error(ctx));
        obs_context_clear_error(ctx);
        g_failed = 1;
    } else {
        printf("  %-20s %8llu triangles, %u instances, %u cameras\n", file,
               (unsigned long long)obs_scene_triangle_count(&g_scene), g_scene.instance_count, g_scene.camera_count);
    }
    sb_reset();
}

/* ------------------------------------------------------------------------------------------------
 * Real meshes
 * ---------------------------------------------------------------------------------------------- */

typedef struct raw_mesh {
    float *pos, *nrm;
    uint32_t *idx, nv, nt;
} raw_mesh;

/* Load an OFF mesh, make its winding outward (positive signed volume), centre it on its
 * bounding-box centre, scale it so that the farthest vertex is at distance `radius` (the same
 * normalisation as the llvmpipe peer), rotate it by ry degrees about +Y, and compute
 * area-weighted vertex normals in double. */
static int load_mesh(obs_context *ctx, const char *dir, const char *file, float radius, float ry, raw_mesh *out)
{
    char path[4096];
    snprintf(path, sizeof path, "%s/%s", dir, file);
    char *text;
    size_t len;
    if (io_read_file(ctx, path, (size_t)1 << 30, &text, &len) != OBS_STATUS_OK) {
        fprintf(stderr, "obscura_mkdata: %s (run scripts/setup.sh to extract the meshes)\n", obs_context_last_error(ctx));
        obs_context_clear_error(ctx);
        return 0;
    }
    obs_status st = off_parse(ctx, path, text, len, &out->pos, &out->nv, &out->idx, &out->nt);
    free(text);
    if (st != OBS_STATUS_OK) {
        fprintf(stderr, "obscura_mkdata: %s\n", obs_context_last_error(ctx));
        obs_context_clear_error(ctx);
        return 0;
    }
    double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY}, c[3], r2 = 0, vol = 0;
    for (uint32_t v = 0; v < out->nv; v++)
        for (int k = 0; k < 3; k++) {
            lo[k] = fmin(lo[k], out->pos[3 * v + k]);
            hi[k] = fmax(hi[k], out->pos[3 * v + k]);
        }
    for (int k = 0; k < 3; k++)
        c[k] = 0.5 * (lo[k] + hi[k]);
    for (uint32_t v = 0; v < out->nv; v++) {
        double d2 = 0;
        for (int k = 0; k < 3; k++)
            d2 += (out->pos[3 * v + k] - c[k]) * (out->pos[3 * v + k] - c[k]);
        r2 = fmax(r2, d2);
    }
    for (uint32_t t = 0; t < out->nt; t++) { /* signed volume (divergence theorem), about c */
        const float *a = &out->pos[3 * out->idx[3 * t]], *b = &out->pos[3 * out->idx[3 * t + 1]],
                    *d = &out->pos[3 * out->idx[3 * t + 2]];
        double ax = a[0] - c[0], ay = a[1] - c[1], az = a[2] - c[2], bx = b[0] - c[0], by = b[1] - c[1],
               bz = b[2] - c[2], dx = d[0] - c[0], dy = d[1] - c[1], dz = d[2] - c[2];
        vol += ax * (by * dz - bz * dy) - ay * (bx * dz - bz * dx) + az * (bx * dy - by * dx);
    }
    if (vol < 0) /* inside out: flip every triangle */
        for (uint32_t t = 0; t < out->nt; t++) {
            uint32_t tmp = out->idx[3 * t + 1];
            out->idx[3 * t + 1] = out->idx[3 * t + 2];
            out->idx[3 * t + 2] = tmp;
        }
    double s = radius / sqrt(r2), cr = cos(ry * OBS_PI / 180.0), sr = sin(ry * OBS_PI / 180.0);
    for (uint32_t v = 0; v < out->nv; v++) {
        double x = (out->pos[3 * v] - c[0]) * s, y = (out->pos[3 * v + 1] - c[1]) * s, z = (out->pos[3 * v + 2] - c[2]) * s;
        out->pos[3 * v] = (float)(cr * x + sr * z);
        out->pos[3 * v + 1] = (float)y;
        out->pos[3 * v + 2] = (float)(-sr * x + cr * z);
    }
    double *acc = (double *)calloc((size_t)out->nv * 3, sizeof(double));
    out->nrm = (float *)malloc((size_t)out->nv * 3 * sizeof(float));
    if (!acc || !out->nrm)
        die("out of memory");
    for (uint32_t t = 0; t < out->nt; t++) {
        const uint32_t *ix = &out->idx[3 * t];
        const float *a = &out->pos[3 * ix[0]], *b = &out->pos[3 * ix[1]], *d = &out->pos[3 * ix[2]];
        double e1[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]}, e2[3] = {d[0] - a[0], d[1] - a[1], d[2] - a[2]};
        double n[3] = {e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0]};
        for (int j = 0; j < 3; j++)
            for (int k = 0; k < 3; k++)
                acc[3 * ix[j] + k] += n[k]; /* |n| = 2 x area: area weighting */
    }
    for (uint32_t v = 0; v < out->nv; v++) {
        double l = sqrt(acc[3 * v] * acc[3 * v] + acc[3 * v + 1] * acc[3 * v + 1] + acc[3 * v + 2] * acc[3 * v + 2]);
        for (int k = 0; k < 3; k++)
            out->nrm[3 * v + k] = l > 0 ? (float)(acc[3 * v + k] / l) : (k == 1 ? 1.0f : 0.0f);
    }
    free(acc);
    return 1;
}

static uint32_t sb_raw_mesh(const char *name, raw_mesh *r, int32_t material)
{
    mb b = {r->pos, r->nrm, r->idx, r->nv, r->nt, r->nv, r->nt};
    memset(r, 0, sizeof *r);
    return sb_mesh(name, &b, material);
}

/* Bounds of a raw mesh. */
static void raw_bounds(const raw_mesh *r, obs_vec3 *lo, obs_vec3 *hi)
{
    *lo = obs_v3(INFINITY, INFINITY, INFINITY);
    *hi = obs_v3(-INFINITY, -INFINITY, -INFINITY);
    for (uint32_t v = 0; v < r->nv; v++) {
        lo->x = fminf(lo->x, r->pos[3 * v]); hi->x = fmaxf(hi->x, r->pos[3 * v]);
        lo->y = fminf(lo->y, r->pos[3 * v + 1]); hi->y = fmaxf(hi->y, r->pos[3 * v + 1]);
        lo->z = fminf(lo->z, r->pos[3 * v + 2]); hi->z = fmaxf(hi->z, r->pos[3 * v + 2]);
    }
}

/* ------------------------------------------------------------------------------------------------
 * Scenes
 * ---------------------------------------------------------------------------------------------- */

static void ground(float half, int cells, int32_t mat)
{
    mb b = {0};
    /* u x v must point up: u = +z extent, v = +x extent */
    mb_grid(&b, obs_v3(-half, 0, -half), obs_v3(0, 0, 2 * half), obs_v3(2 * half, 0, 0), cells, cells);
    sb_instance(sb_mesh("ground", &b, mat), obs_mat4_identity());
}

static void scene_plane(obs_context *ctx, const char *out)
{
    ground(10.0f, 16, sb_material("white", 0.8f, 0.8f, 0.8f));
    sb_camera("default", obs_v3(0, 4, 10), obs_v3(0, 0, 0), 45, 0.1f, 100);
    sb_write(ctx, out, "plane.glb");
}

static void scene_sphere_on_plane(obs_context *ctx, const char *out)
{
    int32_t white = sb_material("white", 0.8f, 0.8f, 0.8f);
    ground(10.0f, 16, white);
    mb b = {0};
    mb_sphere(&b, obs_v3(0, 1, 0), 1.0f, 64, 32);
    sb_instance(sb_mesh("sphere", &b, white), obs_mat4_identity());
    sb_camera("default", obs_v3(0, 2.5f, 6), obs_v3(0, 0.7f, 0), 45, 0.1f, 100);
    sb_camera("view2", obs_v3(4, 1.2f, 3), obs_v3(0, 0.5f, 0), 45, 0.1f, 100);
    sb_write(ctx, out, "sphere_on_plane.glb");
}

static void scene_corner2(obs_context *ctx, const char *out)
{
    int32_t white = sb_material("white", 0.8f, 0.8f, 0.8f);
    mb f = {0}, w = {0};
    /* floor y = 0 for z in [0, 10]; wall z = 0 for y in [0, 10]; both face the corner region */
    mb_grid(&f, obs_v3(-5, 0, 0), obs_v3(0, 0, 10), obs_v3(10, 0, 0), 10, 10);
    mb_grid(&w, obs_v3(-5, 0, 0), obs_v3(10, 0, 0), obs_v3(0, 10, 0), 10, 10);
    sb_instance(sb_mesh("floor", &f, white), obs_mat4_identity());
    sb_instance(sb_mesh("wall", &w, white), obs_mat4_identity());
    sb_camera("default", obs_v3(3, 3, 8), obs_v3(0, 0, 0), 45, 0.1f, 100);
    sb_write(ctx, out, "corner2.glb");
}

static void scene_corner3(obs_context *ctx, const char *out)
{
    int32_t white = sb_material("white", 0.8f, 0.8f, 0.8f);
    mb f = {0}, w1 = {0}, w2 = {0};
    mb_grid(&f, obs_v3(0, 0, 0), obs_v3(0, 0, 10), obs_v3(10, 0, 0), 10, 10);   /* y = 0, up */
    mb_grid(&w1, obs_v3(0, 0, 0), obs_v3(10, 0, 0), obs_v3(0, 10, 0), 10, 10);  /* z = 0, +z */
    mb_grid(&w2, obs_v3(0, 0, 0), obs_v3(0, 10, 0), obs_v3(0, 0, 10), 10, 10);  /* x = 0, +x */
    sb_instance(sb_mesh("floor", &f, white), obs_mat4_identity());
    sb_instance(sb_mesh("back_wall", &w1, white), obs_mat4_identity());
    sb_instance(sb_mesh("side_wall", &w2, white), obs_mat4_identity());
    sb_camera("default", obs_v3(6, 5, 8), obs_v3(0, 0, 0), 45, 0.1f, 100);
    sb_write(ctx, out, "corner3.glb");
}

static void scene_cornell(obs_context *ctx, const char *out)
{
    /* The Cornell box at 5.5 m: x in [0, 5.5], y in [0, 5.5], z in [-5.5, 0], open at z = 0. */
    const float S = 5.5f;
    int32_t white = sb_material("white", 0.73f, 0.73f, 0.73f), red = sb_material("red", 0.65f, 0.05f, 0.05f),
            green = sb_material("green", 0.12f, 0.45f, 0.15f);
    mb fl = {0}, ce = {0}, bk = {0}, lf = {0}, rt = {0};
    mb_grid(&fl, obs_v3(0, 0, -S), obs_v3(0, 0, S), obs_v3(S, 0, 0), 8, 8);       /* floor, up */
    mb_grid(&ce, obs_v3(0, S, -S), obs_v3(S, 0, 0), obs_v3(0, 0, S), 8, 8);       /* ceiling, down */
    mb_grid(&bk, obs_v3(0, 0, -S), obs_v3(S, 0, 0), obs_v3(0, S, 0), 8, 8);       /* back, +z */
    mb_grid(&lf, obs_v3(0, 0, -S), obs_v3(0, S, 0), obs_v3(0, 0, S), 8, 8);       /* left x = 0, +x */
    mb_grid(&rt, obs_v3(S, 0, -S), obs_v3(0, 0, S), obs_v3(0, S, 0), 8, 8);       /* right x = S, -x */
    sb_instance(sb_mesh("floor", &fl, white), obs_mat4_identity());
    sb_instance(sb_mesh("ceiling", &ce, white), obs_mat4_identity());
    sb_instance(sb_mesh("back", &bk, white), obs_mat4_identity());
    sb_instance(sb_mesh("left", &lf, red), obs_mat4_identity());
    sb_instance(sb_mesh("right", &rt, green), obs_mat4_identity());
    /* The two blocks, built at the origin and placed by their node transforms (rotation about Y). */
    mb sb = {0}, tb = {0};
    mb_box(&sb, obs_v3(-0.825f, 0, -0.825f), obs_v3(0.825f, 1.65f, 0.825f), 0);
    mb_box(&tb, obs_v3(-0.825f, 0, -0.825f), obs_v3(0.825f, 3.3f, 0.825f), 0);
    uint32_t short_block = sb_mesh("short_block", &sb, white), tall_block = sb_mesh("tall_block", &tb, white);
    obs_vec4 q1 = {0, (float)sin(-0.5 * 17 * OBS_PI / 180), 0, (float)cos(-0.5 * 17 * OBS_PI / 180)};
    obs_vec4 q2 = {0, (float)sin(0.5 * 17 * OBS_PI / 180), 0, (float)cos(0.5 * 17 * OBS_PI / 180)};
    sb_instance(short_block, obs_mat4_from_trs(obs_v3(3.7f, 0, -1.7f), q1, obs_v3(1, 1, 1)));
    sb_instance(tall_block, obs_mat4_from_trs(obs_v3(1.8f, 0, -3.7f), q2, obs_v3(1, 1, 1)));
    sb_point_light("ceiling_light", obs_v3(2.75f, 5.35f, -2.75f), 100.0f);
    /* The classic view: yfov 39.3 degrees from the box's open side. */
    sb_camera("default", obs_v3(2.75f, 2.75f, 8.0f), obs_v3(2.75f, 2.75f, -2.75f), 39.3f, 0.5f, 30);
    sb_write(ctx, out, "cornell_box.glb");
}

static void scene_closed_box(obs_context *ctx, const char *out)
{
    mb b = {0};
    mb_box(&b, obs_v3(-2, -2, -2), obs_v3(2, 2, 2), 1);
    sb_instance(sb_mesh("box", &b, sb_material("white", 0.8f, 0.8f, 0.8f)), obs_mat4_identity());
    sb_camera("default", obs_v3(0, 0, 1.5f), obs_v3(0, 0, -2), 60, 0.05f, 20);
    sb_write(ctx, out, "closed_box.glb");
}

static int scene_object(obs_context *ctx, const char *out, const char *meshes, const char *off, const char *file,
                        float ry)
{
    raw_mesh r = {0};
    if (!load_mesh(ctx, meshes, off, 1.0f, ry, &r))
        return 0;
    char name[64];
    snprintf(name, sizeof name, "%.*s", (int)(strlen(file) - 4), file);
    sb_instance(sb_raw_mesh(name, &r, sb_material("clay", 0.8f, 0.8f, 0.8f)), obs_mat4_identity());
    /* The peer's framing: the unit bounding sphere fills the vertical field of view. */
    float dist = 1.0f / sinf((float)(22.5 * OBS_PI / 180));
    sb_camera("default", obs_v3(0, 0, dist), obs_v3(0, 0, 0), 45, dist - 1.1f, dist + 1.1f);
    sb_camera("view2", obs_v3(0.6f * dist, 0.4f * dist, 0.7f * dist), obs_v3(0, 0, 0), 45, 0.1f * dist, 2 * dist);
    sb_write(ctx, out, file);
    return 1;
}

static int scene_dragon_plane(obs_context *ctx, const char *out, const char *meshes)
{
    raw_mesh r = {0};
    if (!load_mesh(ctx, meshes, "ChineseDragon-10kv.off", 1.0f, 0.0f, &r))
        return 0;
    /* ~2 m long: scale the longest horizontal extent to 2 m, rest it on y = 0 */
    obs_vec3 lo, hi;
    raw_bounds(&r, &lo, &hi);
    float s = 2.0f / fmaxf(hi.x - lo.x, hi.z - lo.z);
    int32_t white = sb_material("white", 0.8f, 0.8f, 0.8f), jade = sb_material("jade", 0.35f, 0.6f, 0.4f);
    ground(10.0f, 20, white);
    obs_mat4 place = obs_mat4_mul(obs_mat4_translation(obs_v3(0, -lo.y * s, 0)), obs_mat4_scale(obs_v3(s, s, s)));
    sb_instance(sb_raw_mesh("dragon", &r, jade), place);
    sb_camera("default", obs_v3(2.4f, 1.5f, 3.2f), obs_v3(0, 0.55f, 0), 45, 0.1f, 60);
    sb_camera("view2", obs_v3(-3.0f, 2.6f, -2.2f), obs_v3(0, 0.45f, 0), 45, 0.1f, 60);
    sb_write(ctx, out, "dragon_plane.glb");
    return 1;
}

/* ---- Translucent scenes (docs/sss.md, docs/data.md): real sizes in metres, so that the
 * Jensen 2001 coefficients (per mm) apply at the default scale of 1000 mm per unit. ---- */

/* A real mesh about 30 cm across (Dal Corso's bunny is "about 30 cm", sss.md section 3), in one
 * preset, lit by a directional light from the front upper right; a second camera from behind. */
static int scene_translucent_object(obs_context *ctx, const char *out, const char *meshes, const char *off,
                                    const char *file, float ry, const char *preset)
{
    raw_mesh r = {0};
    if (!load_mesh(ctx, meshes, off, 0.15f, ry, &r))
        return 0;
    char name[64];
    snprintf(name, sizeof name, "%.*s", (int)(strlen(file) - 4), file);
    sb_instance(sb_raw_mesh(name, &r, sb_sss_material(preset, preset)), obs_mat4_identity());
    sb_dir_light("key", obs_v3(-0.4f, -0.5f, -0.77f), 1.0f);
    const float dist = 0.15f / sinf((float)(22.5 * OBS_PI / 180));
    sb_camera("default", obs_v3(0, 0, dist), obs_v3(0, 0, 0), 45, dist - 0.2f, dist + 0.2f);
    sb_camera("behind", obs_v3(0.3f * dist, 0.2f * dist, -0.93f * dist), obs_v3(0, 0, 0), 45, 0.02f, 4 * dist);
    sb_write(ctx, out, file);
    return 1;
}

/* Frisvad's dirpole test scene (sss.md section 4): a potato sphere of radius 25 mm, lit by a
 * directional light from normalize(1, 1, -0.5) (the light travels the opposite way). */
static void scene_sphere_potato(obs_context *ctx, const char *out)
{
    mb b = {0};
    mb_icosphere(&b, obs_v3(0, 0, 0), 0.025f, 5);
    sb_instance(sb_mesh("sphere", &b, sb_sss_material("potato", "potato")), obs_mat4_identity());
    sb_dir_light("key", obs_v3(-1.0f, -1.0f, 0.5f), 1.0f);
    sb_camera("default", obs_v3(0, 0, 0.1f), obs_v3(0, 0, 0), 40, 0.05f, 0.15f);
    sb_write(ctx, out, "sphere_potato.glb");
}

/* A thin slab, 100 x 100 x 4 mm, of skim milk, lit from behind: the back-lit case of the
 * directional dipole (x_o straight behind x_i, sss.md 1.3). Faces share no vertices (hard edges);
 * the SSS random walk welds coincident positions to check it is closed. */
static void scene_slab(obs_context *ctx, const char *out)
{
    mb b = {0};
    mb_box(&b, obs_v3(-0.05f, -0.05f, -0.002f), obs_v3(0.05f, 0.05f, 0.002f), 0);
    sb_instance(sb_mesh("slab", &b, sb_sss_material("skimmilk", "skimmilk")), obs_mat4_identity());
    sb_dir_light("back", obs_v3(0.2f, 0.1f, 1.0f), 1.0f);   /* travels towards +z: lights the far face */
    sb_camera("default", obs_v3(0, 0, 0.2f), obs_v3(0, 0, 0), 40, 0.1f, 0.3f);
    sb_write(ctx, out, "slab_skimmilk.glb");
}

/* The default scene of `obscura render` (docs/render.md, the README's main command): the Cornell
 * box of scene_cornell (5.5 m, open at z = 0) holding one of each effect the render composes:
 *   - the tall block, opaque: ambient occlusion where it meets the floor and the back wall;
 *   - the bunny (radius 1.3 units, on the floor, front right), translucent: its material's extras
 *     carry "obscura_sss" (Jensen 2001's marble);
 *   - a small volume, the synthetic buckyball (vol_synth "bucky", 32^3) placed by "box" in the free
 *     space above the left of the tall block (a 1.2-unit cube), composited against the walls' depth;
 *   - one point light above and in front of the opening (below the ceiling's plane, so it lights
 *     the whole inside; outside the box's bounding sphere: sss_light_map_render refuses a point
 *     light inside the bounds of the scene it is given, and this way the scene renders whether the
 *     SSS passes give it the whole scene or only the translucent meshes);
 *   - the camera "default" of scene_cornell.
 * The scene's extras "obscura_render" give the settings that suit its size: SAO's radius 0.5 m
 * (about a tenth of the box; the default 1 m is for a metre-scale scene) and SSS at 25 mm per
 * unit, which makes the 2.6-unit bunny 65 mm across: several of marble's diffusion lengths
 * (1/sigma_tr = 8.5 mm red, 4 mm blue), so light bleeds visibly without washing the shape out
 * (at the default 1000 mm per unit it is 2 m of marble: it looks like an opaque white object).
 * It asks for N = 192 samples per texel (the default is the bar's 48): at 48 the bunny, about one
 * map texel per pixel at 1080p, shows the exponential sampler's per-texel noise as a visible grain
 * (measured: 192 halves it, as 1/sqrt(N) says, for 4.8 s of maps instead of 1.9 s on 2 cores). */
static int scene_cornell_hybrid(obs_context *ctx, const char *out, const char *meshes)
{
    const float S = 5.5f;
    raw_mesh r = {0};
    if (!load_mesh(ctx, meshes, "bunny00.off", 1.3f, -30.0f, &r))
        return 0;
    int32_t white = sb_material("white", 0.73f, 0.73f, 0.73f), red = sb_material("red", 0.65f, 0.05f, 0.05f),
            green = sb_material("green", 0.12f, 0.45f, 0.15f);
    mb fl = {0}, ce = {0}, bk = {0}, lf = {0}, rt = {0};
    mb_grid(&fl, obs_v3(0, 0, -S), obs_v3(0, 0, S), obs_v3(S, 0, 0), 8, 8);       /* floor, up */
    mb_grid(&ce, obs_v3(0, S, -S), obs_v3(S, 0, 0), obs_v3(0, 0, S), 8, 8);       /* ceiling, down */
    mb_grid(&bk, obs_v3(0, 0, -S), obs_v3(S, 0, 0), obs_v3(0, S, 0), 8, 8);       /* back, +z */
    mb_grid(&lf, obs_v3(0, 0, -S), obs_v3(0, S, 0), obs_v3(0, 0, S), 8, 8);       /* left x = 0, +x */
    mb_grid(&rt, obs_v3(S, 0, -S), obs_v3(0, 0, S), obs_v3(0, S, 0), 8, 8);       /* right x = S, -x */
    sb_instance(sb_mesh("floor", &fl, white), obs_mat4_identity());
    sb_instance(sb_mesh("ceiling", &ce, white), obs_mat4_identity());
    sb_instance(sb_mesh("back", &bk, white), obs_mat4_identity());
    sb_instance(sb_mesh("left", &lf, red), obs_mat4_identity());
    sb_instance(sb_mesh("right", &rt, green), obs_mat4_identity());
    mb tb = {0};
    mb_box(&tb, obs_v3(-0.825f, 0, -0.825f), obs_v3(0.825f, 3.3f, 0.825f), 0);
    obs_vec4 q = {0, (float)sin(0.5 * 17 * OBS_PI / 180), 0, (float)cos(0.5 * 17 * OBS_PI / 180)};
    sb_instance(sb_mesh("tall_block", &tb, white), obs_mat4_from_trs(obs_v3(1.8f, 0, -3.7f), q, obs_v3(1, 1, 1)));
    /* The bunny stands on the floor (its lowest vertex at y = 0), front right. */
    obs_vec3 lo, hi;
    raw_bounds(&r, &lo, &hi);
    sb_instance(sb_raw_mesh("bunny", &r, sb_sss_material("marble", "marble")),
                obs_mat4_translation(obs_v3(3.7f, -lo.y, -2.0f)));
    sb_point_light("key", obs_v3(2.75f, 5.0f, 3.0f), 100.0f);
    sb_camera("default", obs_v3(2.75f, 2.75f, 8.0f), obs_v3(2.75f, 2.75f, -2.75f), 39.3f, 0.5f, 30);
    static const char extras[] =
        "{\"obscura_render\":{"
        "\"ao\":{\"method\":\"sao\",\"radius\":0.5},"
        "\"sss\":{\"mm_per_unit\":25,\"N\":192},"
        "\"volume\":{\"source\":\"synth:bucky:32\",\"transfer\":\"bucky\","
        "\"box\":[[0.5,3.6,-2.1],[1.7,4.8,-0.9]],\"light\":0}}}";
    g_scene.extras_json = (char *)malloc(sizeof extras);
    if (!g_scene.extras_json)
        die("out of memory");
    memcpy(g_scene.extras_json, extras, sizeof extras);
    sb_write(ctx, out, "cornell_hybrid.glb");
    return 1;
}

static void scene_village(obs_context *ctx, const char *out)
{
    int32_t grass = sb_material("ground", 0.45f, 0.55f, 0.35f), wall = sb_material("wall", 0.85f, 0.8f, 0.7f),
            roof = sb_material("roof", 0.55f, 0.2f, 0.15f);
    /* The roof is two single quads whose eaves overhang the walls: seen from the street, their
     * undersides face the camera, so the material says double-sided (glTF 2.0 §3.9.5). */
    g_scene.materials[roof].double_sided = 1;
    ground(30.0f, 30, grass);
    /* A two-storey house: a 6 x 6 x 6 m body and a gabled roof with its ridge along x at 8.5 m. */
    mb body = {0}, rf = {0};
    mb_box(&body, obs_v3(-3, 0, -3), obs_v3(3, 6, 3), 0);
    obs_vec3 s1[4] = {{-3.3f, 5.8f, 3.4f}, {3.3f, 5.8f, 3.4f}, {3.3f, 8.5f, 0}, {-3.3f, 8.5f, 0}};
    obs_vec3 s2[4] = {{3.3f, 5.8f, -3.4f}, {-3.3f, 5.8f, -3.4f}, {-3.3f, 8.5f, 0}, {3.3f, 8.5f, 0}};
    obs_vec3 g1[3] = {{3, 6, 3}, {3, 6, -3}, {3, 8.5f, 0}};
    obs_vec3 g2[3] = {{-3, 6, -3}, {-3, 6, 3}, {-3, 8.5f, 0}};
    mb_poly(&rf, s1, 4);
    mb_poly(&rf, s2, 4);
    mb_poly(&body, g1, 3);
    mb_poly(&body, g2, 3);
    uint32_t hb = sb_mesh("house_body", &body, wall), hr = sb_mesh("house_roof", &rf, roof);
    for (int row = 0; row < 2; row++)
        for (int k = 0; k < 3; k++) {
            obs_mat4 w = obs_mat4_translation(obs_v3(-14.0f + 14.0f * k, 0, row ? 9.0f : -9.0f));
            sb_instance(hb, w);
            sb_instance(hr, w);
        }
    sb_camera("default", obs_v3(-24, 1.7f, 1.0f), obs_v3(10, 3.5f, -1.0f), 50, 0.1f, 150);
    sb_camera("view2", obs_v3(26, 30, 34), obs_v3(0, 2, 0), 45, 1.0f, 200);
    sb_write(ctx, out, "village.glb");
}

static void scene_room(obs_context *ctx, const char *out)
{
    int32_t wallm = sb_material("wall", 0.85f, 0.85f, 0.82f), wood = sb_material("wood", 0.55f, 0.35f, 0.2f),
            fabric = sb_material("fabric", 0.3f, 0.35f, 0.6f);
    mb room = {0}, table = {0}, chair = {0}, shelf = {0}, sofa = {0};
    mb_box(&room, obs_v3(-4, 0, -3), obs_v3(4, 3, 3), 1); /* 8 x 3 x 6 m, seen from inside */
    /* table: 1.6 x 0.9 top at 0.75 m, four legs */
    mb_box(&table, obs_v3(-0.8f, 0.72f, -0.45f), obs_v3(0.8f, 0.77f, 0.45f), 0);
    for (int i = 0; i < 4; i++) {
        float x = i & 1 ? 0.7f : -0.76f, z = i & 2 ? 0.35f : -0.41f;
        mb_box(&table, obs_v3(x, 0, z), obs_v3(x + 0.06f, 0.72f, z + 0.06f), 0);
    }
    /* chair: seat at 0.45 m, legs, back */
    mb_box(&chair, obs_v3(-0.22f, 0.42f, -0.22f), obs_v3(0.22f, 0.47f, 0.22f), 0);
    for (int i = 0; i < 4; i++) {
        float x = i & 1 ? 0.17f : -0.22f, z = i & 2 ? 0.17f : -0.22f;
        mb_box(&chair, obs_v3(x, 0, z), obs_v3(x + 0.05f, 0.42f, z + 0.05f), 0);
    }
    /* the back on the chair's -z side: a chair faces +z (an unrotated chair south of the table faces it) */
    mb_box(&chair, obs_v3(-0.22f, 0.47f, -0.22f), obs_v3(0.22f, 0.95f, -0.18f), 0);
    /* bookshelf against the back wall: sides, back, five shelves */
    mb_box(&shelf, obs_v3(-0.6f, 0, -0.175f), obs_v3(-0.57f, 2.0f, 0.175f), 0);
    mb_box(&shelf, obs_v3(0.57f, 0, -0.175f), obs_v3(0.6f, 2.0f, 0.175f), 0);
    mb_box(&shelf, obs_v3(-0.6f, 0, -0.175f), obs_v3(0.6f, 2.0f, -0.155f), 0);
    for (int k = 0; k < 5; k++)
        mb_box(&shelf, obs_v3(-0.57f, 0.05f + 0.47f * k, -0.155f), obs_v3(0.57f, 0.08f + 0.47f * k, 0.175f), 0);
    /* sofa: base, back, arms */
    mb_box(&sofa, obs_v3(-1.0f, 0, -0.45f), obs_v3(1.0f, 0.45f, 0.45f), 0);
    mb_box(&sofa, obs_v3(-1.0f, 0.45f, -0.45f), obs_v3(1.0f, 0.9f, -0.25f), 0);
    mb_box(&sofa, obs_v3(-1.0f, 0.45f, -0.25f), obs_v3(-0.8f, 0.7f, 0.45f), 0);
    mb_box(&sofa, obs_v3(0.8f, 0.45f, -0.25f), obs_v3(1.0f, 0.7f, 0.45f), 0);
    sb_instance(sb_mesh("room", &room, wallm), obs_mat4_identity());
    sb_instance(sb_mesh("table", &table, wood), obs_mat4_translation(obs_v3(0.5f, 0, 0.3f)));
    uint32_t ch = sb_mesh("chair", &chair, wood);
    obs_vec4 turn = {0, 1, 0, 0}; /* 180 degrees about Y */
    sb_instance(ch, obs_mat4_translation(obs_v3(0.3f, 0, -0.55f)));
    sb_instance(ch, obs_mat4_from_trs(obs_v3(0.8f, 0, 1.15f), turn, obs_v3(1, 1, 1)));
    sb_instance(sb_mesh("bookshelf", &shelf, wood), obs_mat4_translation(obs_v3(-2.2f, 0, -2.82f)));
    sb_instance(sb_mesh("sofa", &sofa, fabric), obs_mat4_translation(obs_v3(-2.4f, 0, 1.5f)));
    sb_point_light("ceiling_light", obs_v3(0, 2.9f, 0), 50.0f);
    sb_camera("default", obs_v3(3.5f, 1.6f, 2.5f), obs_v3(-1.0f, 0.8f, -1.0f), 60, 0.05f, 20);
    sb_camera("view2", obs_v3(-3.5f, 2.2f, 2.5f), obs_v3(1.0f, 0.5f, -1.5f), 60, 0.05f, 20);
    sb_write(ctx, out, "room.glb");
}

/* mkdir -p: each missing component of dir, mode 0777 (less the umask). Returns 0 or -1 (errno). */
static int make_dirs(const char *dir)
{
    char p[4096];
    size_t n = strlen(dir);
    if (n == 0 || n >= sizeof p) {
        errno = ENAMETOOLONG;
        return -1;
    }
    memcpy(p, dir, n + 1);
    for (size_t i = 1; i <= n; i++) {
        if (p[i] == '/' || p[i] == '\0') {
            char saved = p[i];
            p[i] = '\0';
            if (mkdir(p, 0777) != 0 && errno != EEXIST)
                return -1;
            p[i] = saved;
        }
    }
    struct stat st;
    if (stat(dir, &st) != 0)
        return -1;
    if (!S_ISDIR(st.st_mode)) {
        errno = ENOTDIR;
        return -1;
    }
    return 0;
}

int main(int argc, char **argv)
{
    const char *out = NULL, *meshes = NULL;
    for (int i = 1; i < argc; i++) {
        if (!strcmp(argv[i], "--out") && i + 1 < argc)
            out = argv[++i];
        else if (!strcmp(argv[i], "--meshes") && i + 1 < argc)
            meshes = argv[++i];
        else {
            fprintf(stderr, "usage: obscura_mkdata --out DIR --meshes DIR_WITH_OFF_FILES\n");
            return 2;
        }
    }
    if (!out || !meshes) {
        fprintf(stderr, "usage: obscura_mkdata --out DIR --meshes DIR_WITH_OFF_FILES\n");
        return 2;
    }
    /* The meshes first: a missing one is named before anything is written. */
    static const char *const offs[] = {"bunny00.off", "ChineseDragon-10kv.off", "armadillo.off"};
    int missing = 0;
    for (size_t k = 0; k < sizeof offs / sizeof offs[0]; k++) {
        char path[4096];
        struct stat stt;
        snprintf(path, sizeof path, "%s/%s", meshes, offs[k]);
        int found = stat(path, &stt) == 0;
        if (!found || !S_ISREG(stt.st_mode)) {
            fprintf(stderr, "obscura_mkdata: missing mesh '%s' (%s); run scripts/setup.sh to extract it\n", path,
                    found ? "not a regular file" : strerror(errno));
            missing = 1;
        }
    }
    if (missing)
        return 1;
    if (make_dirs(out) != 0) {
        fprintf(stderr, "obscura_mkdata: cannot create the output directory '%s': %s\n", out, strerror(errno));
        return 1;
    }
    obs_context *ctx = obs_context_create();
    if (!ctx)
        die("out of memory");
    obs_scene_init(&g_scene);
    printf("obscura_mkdata: writing scenes to %s\n", out);
    scene_plane(ctx, out);
    scene_sphere_on_plane(ctx, out);
    scene_corner2(ctx, out);
    scene_corner3(ctx, out);
    scene_cornell(ctx, out);
    scene_closed_box(ctx, out);
    scene_village(ctx, out);
    scene_room(ctx, out);
    int ok = scene_object(ctx, out, meshes, "bunny00.off", "bunny.glb", 0.0f);
    ok &= scene_object(ctx, out, meshes, "ChineseDragon-10kv.off", "dragon.glb", 0.0f);
    ok &= scene_object(ctx, out, meshes, "armadillo.off", "armadillo.glb", 180.0f); /* seen from the front */
    ok &= scene_dragon_plane(ctx, out, meshes);
    ok &= scene_translucent_object(ctx, out, meshes, "bunny00.off", "bunny_cream.glb", 0.0f, "cream");
    ok &= scene_translucent_object(ctx, out, meshes, "ChineseDragon-10kv.off", "dragon_skin.glb", 0.0f, "skin1");
    ok &= scene_translucent_object(ctx, out, meshes, "armadillo.off", "armadillo_marble.glb", 180.0f, "marble");
    scene_sphere_potato(ctx, out);
    scene_slab(ctx, out);
    ok &= scene_cornell_hybrid(ctx, out, meshes);
    obs_scene_free(&g_scene);
    obs_context_destroy(ctx);
    return ok && !g_failed ? 0 : 1;
}
