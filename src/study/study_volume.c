/* study_volume.c: the volume-lighting study (study_volume.h; docs/volume/truth.md, "The study"):
 * options, datasets, the references, one point (run and error functions), the sweep and the report. */
#include "study_volume.h"

#include "../io/io.h"
#include "../render/render.h"
#include "../truth/truth.h"
#include "../volume/vol.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* The fixed scene of every dataset (ours): a directional light travelling along
 * normalize(0.4, -0.7, -0.6) (from above, to one side: no axis-aligned special case), the camera of
 * `obscura volume` (looking along (-0.3, -0.4, -1) at the volume's centre, framing it, 40 degrees). */
static const double study_volume_light_dir[3] = {0.4, -0.7, -0.6};
static const double study_volume_cam_dir[3] = {-0.3, -0.4, -1.0};

/* The seed's Table 5.4 (GTX 660, 8 samples per fragment, light volume at the data's size; ms):
 * scene change / fixed scene. Our cranium and MRI stand in for its bonsai and engine (not available
 * offline; issue 15 item 10). */
typedef struct seed_row {
    const char *ours, *seed_name;
    double change_ms, fixed_ms;
} seed_row;
static const seed_row study_volume_seed[] = {
    {"bucky", "bucky", 6.04, 1.41},
    {"cranium", "bonsai", 34.99, 8.86},
    {"mri", "engine", 34.79, 7.98},
};

/* The seed's Table 5.5 (GTX 660; "Rendering de la escena (ms)", the final rendering of a mesh and a
 * volume together in a Cornell box). Bonsai and the Hebe statue are not available offline: the head
 * CT stands in for the bonsai (as in Table 5.4's layout) and the Stanford bunny (75,408 triangles,
 * our largest mesh, as the Hebe statue is the seed's larger one: its times are the higher) for Hebe. */
typedef struct seed_hybrid_row {
    const char *volume, *mesh, *seed_pair;
    double ms;
} seed_hybrid_row;
static const seed_hybrid_row study_volume_seed_hybrid[] = {
    {"bucky", "bunny", "bucky + Hebe", 12.63},
    {"bucky", "dragon", "bucky + Stanford dragon", 5.73},
    {"cranium", "bunny", "bonsai + Hebe", 13.62},
    {"cranium", "dragon", "bonsai + Stanford dragon", 5.07},
};
#define SV_HYBRID_PAIRS 4

#ifndef OBS_STUDY_DATA_DIR
#define OBS_STUDY_DATA_DIR "build/data"
#endif

/* ================================================================================================
 * Options and the table
 * ============================================================================================== */

study_volume_options study_volume_options_default(void)
{
    study_volume_options o;
    memset(&o, 0, sizeof o);
    o.out_dir = "out/study-volume";
    o.volume_dir = "data/cache/volumes";
    o.datasets = STUDY_VOLUME_DEFAULT_DATASETS;
    o.scales = STUDY_VOLUME_DEFAULT_SCALES;
    o.cones = STUDY_VOLUME_DEFAULT_CONES;
    o.blends = STUDY_VOLUME_DEFAULT_BLENDS;
    o.steps = STUDY_VOLUME_DEFAULT_STEPS;
    o.size = STUDY_VOLUME_DEFAULT_SIZE;
    o.runs = STUDY_VOLUME_DEFAULT_RUNS;
    o.ref_samples = STUDY_VOLUME_DEFAULT_REF_SAMPLES;
    o.l_voxels = STUDY_VOLUME_DEFAULT_L_VOXELS;
    o.t_step = STUDY_VOLUME_DEFAULT_T_STEP;
    o.data_dir = OBS_STUDY_DATA_DIR;
    return o;
}

study_volume_options study_volume_options_quick(void)
{
    study_volume_options o = study_volume_options_default();
    o.datasets = STUDY_VOLUME_QUICK_DATASETS;
    o.cones = STUDY_VOLUME_QUICK_CONES;
    o.steps = STUDY_VOLUME_QUICK_STEPS;
    o.size = STUDY_VOLUME_QUICK_SIZE;
    o.runs = STUDY_VOLUME_QUICK_RUNS;
    o.ref_samples = STUDY_VOLUME_QUICK_REF_SAMPLES;
    o.t_step = STUDY_VOLUME_QUICK_T_STEP;
    o.quick = 1;
    return o;
}

const char *const study_volume_columns[] = {
    "dataset", "method", "scale", "cone", "blend", "step",                       /* key */
    "nx", "ny", "nz", "width", "height", "status", "threads",
    "lv_ms", "lv_ms_min", "lv_ms_max", "rc_ms", "rc_ms_min", "rc_ms_max", "scene_change_ms", "fixed_ms",
    "l_rmse", "l_mean_abs", "l_max_abs", "l_mean_signed", "l_voxels",
    "img_rmse", "img_rmse_nc", "img_bias", "img_rel_rmse",
    "lonly_rmse", "lonly_rmse_nc", "lonly_bias", "lonly_rel_rmse",
    "ref_noise_rms", "ref_samples", "ref_seconds", "pixels",
};
const int study_volume_column_count = (int)(sizeof study_volume_columns / sizeof study_volume_columns[0]);

const char *const study_volume_hybrid_columns[] = {
    "volume", "mesh",                                                            /* key */
    "triangles", "width", "height", "status", "threads",
    "lv_ms", "frame_ms", "frame_ms_min", "frame_ms_max", "scene_change_ms", "fixed_ms", "cold_frame_ms",
    "seed_pair", "seed_ms",
};
const int study_volume_hybrid_column_count =
    (int)(sizeof study_volume_hybrid_columns / sizeof study_volume_hybrid_columns[0]);

struct study_volume {
    study_volume_options o;
    study_axis datasets, scales, cones, blends, steps;
    int W, H;
    study_table table;
    study_table hybrid;             /* the hybrid stage's rows (OUT/hybrid.csv) */
    char csv[4200], json[4200], hcsv[4200];
    int present[STUDY_AXIS_MAX];    /* per dataset: its file exists (bucky: always) */
    char missing[STUDY_AXIS_MAX][4300];
};

const study_table *study_volume_table(const study_volume *s) { return &s->table; }
const study_table *study_volume_hybrid_table(const study_volume *s) { return &s->hybrid; }

static const char *dataset_file(const char *name)
{
    if (!strcmp(name, "cranium"))
        return "cranium.nrrd";
    if (!strcmp(name, "mri"))
        return "ch2better.nii.gz";
    return NULL;
}

static const char *dataset_tf(const char *name)
{
    if (!strcmp(name, "cranium"))
        return "ct-skin";
    if (!strcmp(name, "mri"))
        return "mri";
    return "bucky";
}

static obs_status check_num_axis(obs_context *ctx, const study_axis *a, const char *what, double lo, double hi,
                                 int integer)
{
    for (int i = 0; i < a->n; i++) {
        char *end;
        double v = strtod(a->v[i], &end);
        if (*end || end == a->v[i] || !(v >= lo && v <= hi) || (integer && v != floor(v)))
            return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "study volume: %s '%s' is not %s in [%g, %g]", what,
                             a->v[i], integer ? "an integer" : "a number", lo, hi);
    }
    return OBS_STATUS_OK;
}

obs_status study_volume_open(obs_context *ctx, const study_volume_options *o, study_volume **out)
{
    if (!out)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "study volume: out is NULL");
    *out = NULL;
    if (!o || !o->out_dir || !o->out_dir[0] || !o->volume_dir)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "study volume: options or out_dir missing");
    study_volume *s = (study_volume *)calloc(1, sizeof *s);
    if (!s)
        return obs_error(ctx, OBS_STATUS_OUT_OF_MEMORY, "study volume: out of memory");
    s->o = *o;
    obs_status st = study_axis_parse(ctx, "datasets", o->datasets, &s->datasets);
    if (st == OBS_STATUS_OK)
        st = study_axis_parse(ctx, "scales", o->scales, &s->scales);
    if (st == OBS_STATUS_OK)
        st = study_axis_parse(ctx, "cones", o->cones, &s->cones);
    if (st == OBS_STATUS_OK)
        st = study_axis_parse(ctx, "blends", o->blends, &s->blends);
    if (st == OBS_STATUS_OK)
        st = study_axis_parse(ctx, "steps", o->steps, &s->steps);
    for (int i = 0; st == OBS_STATUS_OK && i < s->datasets.n; i++) {
        const char *d = s->datasets.v[i];
        if (strcmp(d, "bucky") && strcmp(d, "cranium") && strcmp(d, "mri"))
            st = obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "study volume: dataset '%s' is not bucky, cranium or mri",
                           d);
    }
    for (int i = 0; st == OBS_STATUS_OK && i < s->scales.n; i++)
        if (strcmp(s->scales.v[i], "1") && strcmp(s->scales.v[i], "2") && strcmp(s->scales.v[i], "4"))
            st = obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "study volume: scale '%s' is not 1, 2 or 4",
                           s->scales.v[i]);
    if (st == OBS_STATUS_OK)
        st = check_num_axis(ctx, &s->cones, "cone angle", 1e-3, 80.0, 0);
    if (st == OBS_STATUS_OK)
        st = check_num_axis(ctx, &s->blends, "blend", 0.0, 1.0, 1);
    if (st == OBS_STATUS_OK)
        st = check_num_axis(ctx, &s->steps, "step", 1e-3, 4.0, 0);
    if (st == OBS_STATUS_OK && (!o->size || !obs_parse_size(o->size, 16384, &s->W, &s->H)))
        st = obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "study volume: size '%s' is not WxH", o->size ? o->size : "");
    if (st == OBS_STATUS_OK && (o->runs < 1 || o->runs > 64))
        st = obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "study volume: runs %d is not in [1, 64]", o->runs);
    if (st == OBS_STATUS_OK && (o->ref_samples < 8 || o->ref_samples > (1 << 20) || o->ref_samples % 8))
        st = obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT,
                       "study volume: reference samples %lld is not a multiple of 8 in [8, 1048576]", o->ref_samples);
    if (st == OBS_STATUS_OK && o->l_voxels < 1)
        st = obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "study volume: l_voxels %lld must be >= 1", o->l_voxels);
    if (st == OBS_STATUS_OK && !(o->t_step > 0.0 && o->t_step <= 1.0))
        st = obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "study volume: t_step %g is not in (0, 1]", o->t_step);
    for (int i = 0; st == OBS_STATUS_OK && i < s->datasets.n; i++) {
        const char *f = dataset_file(s->datasets.v[i]);
        s->present[i] = 1;
        if (f) {
            char path[4200];
            snprintf(path, sizeof path, "%s/%s", o->volume_dir, f);
            FILE *fp = fopen(path, "rb");
            if (fp)
                fclose(fp);
            else {
                s->present[i] = 0;
                snprintf(s->missing[i], sizeof s->missing[i], "%s not found (scripts/fetch_volumes.sh)", path);
            }
        }
    }
    if (st == OBS_STATUS_OK)
        st = study_table_init(ctx, &s->table, study_volume_columns, study_volume_column_count,
                              STUDY_VOLUME_KEY_COLUMNS);
    snprintf(s->csv, sizeof s->csv, "%s/results.csv", o->out_dir);
    snprintf(s->json, sizeof s->json, "%s/results.json", o->out_dir);
    int64_t read = 0;
    if (st == OBS_STATUS_OK)
        st = study_table_read_csv(ctx, &s->table, s->csv, &read);
    if (st == OBS_STATUS_OK && read && o->log)
        fprintf(o->log, "obscura: study volume: resuming: %lld points in %s\n", (long long)read, s->csv);
    snprintf(s->hcsv, sizeof s->hcsv, "%s/hybrid.csv", o->out_dir);
    if (st == OBS_STATUS_OK)
        st = study_table_init(ctx, &s->hybrid, study_volume_hybrid_columns, study_volume_hybrid_column_count, 2);
    if (st == OBS_STATUS_OK)
        st = study_table_read_csv(ctx, &s->hybrid, s->hcsv, &read);
    if (st == OBS_STATUS_OK && !o->no_hybrid && !o->data_dir)
        st = obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "study volume: the hybrid stage needs data_dir");
    if (st != OBS_STATUS_OK) {
        study_volume_close(s);
        return st;
    }
    *out = s;
    return OBS_STATUS_OK;
}

void study_volume_close(study_volume *s)
{
    if (!s)
        return;
    study_axis_free(&s->datasets);
    study_axis_free(&s->scales);
    study_axis_free(&s->cones);
    study_axis_free(&s->blends);
    study_axis_free(&s->steps);
    study_table_free(&s->table);
    study_table_free(&s->hybrid);
    free(s);
}

int64_t study_volume_points(const study_volume *s, int *datasets_present)
{
    int present = 0;
    for (int i = 0; i < s->datasets.n; i++)
        present += s->present[i];
    if (datasets_present)
        *datasets_present = present;
    return (int64_t)present * s->steps.n * ((int64_t)s->scales.n * s->cones.n * s->blends.n + 2);
}

/* ================================================================================================
 * One dataset: the frame and the references
 * ============================================================================================== */

typedef struct sv_frame {
    vol_grid grid;
    vol_tf tf;
    vol_light light;
    obs_camera cam;
    truth_volume_image ref;         /* the MC reference */
    double ref_seconds;
    /* exact T on the lattice of each scale (index into s->scales) */
    float *T[STUDY_AXIS_MAX];
    int stride[STUDY_AXIS_MAX];
    int64_t lattice[STUDY_AXIS_MAX];
} sv_frame;

static void sv_frame_free(sv_frame *f)
{
    vol_grid_free(&f->grid);
    vol_tf_free(&f->tf);
    truth_volume_image_free(&f->ref);
    for (int i = 0; i < STUDY_AXIS_MAX; i++)
        free(f->T[i]);
    memset(f, 0, sizeof *f);
}

static obs_status sv_load(obs_context *ctx, const study_volume *s, const char *name, sv_frame *f)
{
    obs_status st;
    if (!strcmp(name, "bucky")) {
        st = vol_synth(ctx, "bucky", 32, &f->grid); /* the seed's bucky is 32^3 (issue 15 item 7) */
    } else {
        char path[4200];
        snprintf(path, sizeof path, "%s/%s", s->o.volume_dir, dataset_file(name));
        io_volume_options vo = io_volume_options_default();
        st = io_volume_load(ctx, path, &vo, &f->grid);
    }
    if (st == OBS_STATUS_OK)
        st = vol_tf_preset(ctx, dataset_tf(name), &f->tf);
    if (st != OBS_STATUS_OK)
        return st;
    /* The camera and light of `obscura volume` (cmd_volume.c frames the same way). */
    double lo[3], hi[3];
    vol_grid_bounds(&f->grid, lo, hi);
    obs_vec3 ctr = obs_v3((float)(0.5 * (lo[0] + hi[0])), (float)(0.5 * (lo[1] + hi[1])), (float)(0.5 * (lo[2] + hi[2])));
    const double rad = 0.5 * sqrt((hi[0] - lo[0]) * (hi[0] - lo[0]) + (hi[1] - lo[1]) * (hi[1] - lo[1]) +
                                  (hi[2] - lo[2]) * (hi[2] - lo[2]));
    const double *cd = study_volume_cam_dir;
    const double cn = sqrt(cd[0] * cd[0] + cd[1] * cd[1] + cd[2] * cd[2]);
    const double yfov = 40.0 * 3.14159265358979323846 / 180.0, dist = rad / sin(0.5 * yfov) * 1.05;
    obs_vec3 eye = obs_v3((float)(ctr.x - cd[0] / cn * dist), (float)(ctr.y - cd[1] / cn * dist),
                          (float)(ctr.z - cd[2] / cn * dist));
    f->cam = obs_camera_look_at(eye, ctr, obs_v3(0, 1, 0), (float)yfov, (float)fmax(1e-3 * dist, dist - 1.2 * rad),
                                (float)(dist + 1.2 * rad));
    f->cam.aspect = (float)s->W / (float)s->H;
    memset(&f->light, 0, sizeof f->light);
    f->light.type = OBS_LIGHT_DIRECTIONAL;
    const double *ld = study_volume_light_dir;
    const double ln = sqrt(ld[0] * ld[0] + ld[1] * ld[1] + ld[2] * ld[2]);
    for (int a = 0; a < 3; a++)
        f->light.direction[a] = ld[a] / ln;
    f->light.color[0] = f->light.color[1] = f->light.color[2] = 1.0f;
    return OBS_STATUS_OK;
}

/* Exact T at the lattice voxels of a light volume (every stride-th voxel on each axis). */
typedef struct sv_tjob {
    const vol_grid *g;
    const vol_tf *tf;
    const vol_light *light;
    truth_volume_params tp;
    const vol_light_volume *lv;
    int stride, lx, ly;
    float *T;
} sv_tjob;

static void sv_t_slice(void *user, int64_t task, int thread)
{
    (void)thread;
    const sv_tjob *J = (const sv_tjob *)user;
    const vol_light_volume *lv = J->lv;
    int k = (int)task * J->stride;
    for (int jj = 0; jj < J->ly; jj++)
        for (int ii = 0; ii < J->lx; ii++) {
            int i = ii * J->stride, j = jj * J->stride;
            double x[3] = {lv->origin[0] + i * lv->spacing[0], lv->origin[1] + j * lv->spacing[1],
                           lv->origin[2] + k * lv->spacing[2]};
            J->T[((size_t)task * J->ly + jj) * J->lx + ii] =
                (float)truth_volume_transmittance_at(J->g, J->tf, J->light, &J->tp, x);
        }
}

static int lattice_stride(int64_t voxels, long long most)
{
    int s = 1;
    while (voxels > (int64_t)most * s * s * s)
        s++;
    return s;
}

static obs_status sv_exact_T(obs_context *ctx, obs_pool *pool, const study_volume *s, sv_frame *f, int si,
                             const vol_light_volume *lv)
{
    if (f->T[si])
        return OBS_STATUS_OK;
    sv_tjob J;
    memset(&J, 0, sizeof J);
    J.g = &f->grid;
    J.tf = &f->tf;
    J.light = &f->light;
    J.tp = truth_volume_params_default();
    J.tp.step_fraction = s->o.t_step;
    J.lv = lv;
    J.stride = lattice_stride((int64_t)lv->nx * lv->ny * lv->nz, s->o.l_voxels);
    J.lx = (lv->nx + J.stride - 1) / J.stride;
    J.ly = (lv->ny + J.stride - 1) / J.stride;
    int lz = (lv->nz + J.stride - 1) / J.stride;
    J.T = (float *)malloc((size_t)J.lx * J.ly * lz * sizeof(float));
    if (!J.T)
        return obs_error(ctx, OBS_STATUS_OUT_OF_MEMORY, "study volume: out of memory (exact transmittance)");
    obs_pool_run(pool, lz, sv_t_slice, &J);
    f->T[si] = J.T;
    f->stride[si] = J.stride;
    f->lattice[si] = (int64_t)J.lx * J.ly * lz;
    return OBS_STATUS_OK;
}

/* ================================================================================================
 * One point
 * ============================================================================================== */

typedef struct sv_img_err {
    double rmse, rmse_nc, bias, rel, noise;
    int64_t pixels;
} sv_img_err;

/* RGB error of img against the reference over the pixels either covers (alpha > 0), the reference's
 * noise s^2 = mean of its replicate SE^2 over the same pixel-channels taken out (docs/study.md). */
static sv_img_err sv_image_error(const obs_image_f32 img[4], const truth_volume_image *ref)
{
    sv_img_err e;
    memset(&e, 0, sizeof e);
    double se2 = 0.0, d2 = 0.0, ds = 0.0, r2 = 0.0;
    int64_t n = 0;
    for (int y = 0; y < ref->height; y++) {
        const float *ia = obs_image_f32_row(&img[3], y), *ra = obs_image_f32_row(&ref->rgba[3], y);
        for (int x = 0; x < ref->width; x++) {
            if (!(ia[x] > 0.0f) && !(ra[x] > 0.0f))
                continue;
            e.pixels++;
            for (int q = 0; q < 3; q++) {
                double a = obs_image_f32_row(&img[q], y)[x], b = obs_image_f32_row(&ref->rgba[q], y)[x];
                double se = obs_image_f32_row(&ref->std_error[q], y)[x];
                d2 += (a - b) * (a - b);
                ds += a - b;
                r2 += b * b;
                se2 += se * se;
                n++;
            }
        }
    }
    if (n == 0)
        return e;
    e.rmse = sqrt(d2 / n);
    e.noise = sqrt(se2 / n);
    e.rmse_nc = study_noise_corrected(e.rmse, e.noise);
    e.bias = ds / n;
    e.rel = r2 > 0.0 ? e.rmse_nc / sqrt(r2 / n) : NAN;
    return e;
}

static void set_num(obs_context *ctx, study_table *t, int64_t row, const char *col, double v)
{
    char buf[64];
    if (isnan(v))
        buf[0] = '\0';
    else
        snprintf(buf, sizeof buf, "%.9g", v);
    study_table_set(ctx, t, row, study_table_column(t, col), buf);
}

static void set_str(obs_context *ctx, study_table *t, int64_t row, const char *col, const char *v)
{
    study_table_set(ctx, t, row, study_table_column(t, col), v);
}

/* One light-volume configuration (scale, cone, blend), built once for every step of the ray caster
 * (the light volume depends on neither the view nor the step): its build times and l's error. */
typedef struct sv_built {
    vol_light_volume lv;
    study_stats sl;
    double l_rmse, l_mean_abs, l_max_abs, l_mean_signed, l_voxels;
    obs_status st;
    char msg[300];
} sv_built;

static void sv_build(obs_context *ctx, obs_pool *pool, const study_volume *s, sv_frame *f, const char *const *key,
                     int si, sv_built *b)
{
    memset(b, 0, sizeof *b);
    vol_lv_params lp = vol_lv_params_default();
    lp.scale = atoi(key[2]);
    lp.cone_angle_deg = atof(key[3]);
    lp.blend_second = atoi(key[4]);
    double *t_lv = (double *)calloc((size_t)s->o.runs, sizeof(double));
    obs_status st = t_lv ? OBS_STATUS_OK : obs_error(ctx, OBS_STATUS_OUT_OF_MEMORY, "study volume: out of memory");
    /* run: the light-volume build, `runs` times */
    for (int r = 0; r < s->o.runs && st == OBS_STATUS_OK; r++) {
        vol_light_volume_free(&b->lv);
        double t0 = obs_time_now();
        st = vol_light_volume_build(ctx, pool, &f->grid, &f->tf, &f->light, &lp, &b->lv);
        t_lv[r] = 1e3 * (obs_time_now() - t0);
    }
    if (st == OBS_STATUS_OK)
        b->sl = study_stats_of(t_lv, s->o.runs);
    free(t_lv);
    /* error: l against the exact transmittance on the lattice */
    if (st == OBS_STATUS_OK)
        st = sv_exact_T(ctx, pool, s, f, si, &b->lv);
    if (st == OBS_STATUS_OK) {
        const vol_light_volume *lv = &b->lv;
        const int S = f->stride[si];
        const int lx = (lv->nx + S - 1) / S, ly = (lv->ny + S - 1) / S, lz = (lv->nz + S - 1) / S;
        double sum = 0.0, sum2 = 0.0, sums = 0.0, mx = 0.0;
        for (int kk = 0; kk < lz; kk++)
            for (int jj = 0; jj < ly; jj++)
                for (int ii = 0; ii < lx; ii++) {
                    size_t v = ((size_t)kk * S * lv->ny + (size_t)jj * S) * lv->nx + (size_t)ii * S;
                    double e = (double)lv->l[v] - (double)f->T[si][((size_t)kk * ly + jj) * lx + ii];
                    sum += fabs(e);
                    sum2 += e * e;
                    sums += e;
                    if (fabs(e) > mx)
                        mx = fabs(e);
                }
        double n = (double)f->lattice[si];
        b->l_rmse = sqrt(sum2 / n);
        b->l_mean_abs = sum / n;
        b->l_max_abs = mx;
        b->l_mean_signed = sums / n;
        b->l_voxels = n;
    }
    b->st = st;
    if (st != OBS_STATUS_OK) {
        snprintf(b->msg, sizeof b->msg, "%s", obs_context_last_error(ctx));
        obs_context_clear_error(ctx);
    }
}

/* Measure one point into a new row. method: "lightvolume" (b: its built light volume), "ea" or
 * "phong" (b NULL). */
static obs_status sv_point(obs_context *ctx, obs_pool *pool, study_volume *s, sv_frame *f, const char *const *key,
                           const sv_built *b, int threads)
{
    const char *method = key[1];
    const char *vals[STUDY_MAX_COLUMNS] = {0};
    for (int c = 0; c < STUDY_VOLUME_KEY_COLUMNS; c++)
        vals[c] = key[c];
    obs_status st = study_table_append(ctx, &s->table, vals);
    if (st != OBS_STATUS_OK)
        return st;
    const int64_t row = s->table.rows - 1;
    set_num(ctx, &s->table, row, "nx", f->grid.nx);
    set_num(ctx, &s->table, row, "ny", f->grid.ny);
    set_num(ctx, &s->table, row, "nz", f->grid.nz);
    set_num(ctx, &s->table, row, "width", s->W);
    set_num(ctx, &s->table, row, "height", s->H);
    set_num(ctx, &s->table, row, "threads", threads);
    set_num(ctx, &s->table, row, "ref_samples", (double)s->o.ref_samples);
    set_num(ctx, &s->table, row, "ref_seconds", f->ref_seconds);

    vol_rc_params rp = vol_rc_params_default();
    double smin = fmin(f->grid.spacing[0], fmin(f->grid.spacing[1], f->grid.spacing[2]));
    rp.step = atof(key[5]) * smin;
    obs_image_f32 img[4] = {{0}}, img1[4] = {{0}};
    float *ones = NULL;
    double *t_rc = (double *)calloc((size_t)s->o.runs, sizeof(double));
    if (!t_rc)
        return obs_error(ctx, OBS_STATUS_OUT_OF_MEMORY, "study volume: out of memory");
    study_stats sl = {NAN, NAN, NAN, 0};
    const vol_light_volume *lvp = NULL;
    if (!strcmp(method, "lightvolume")) {
        rp.shading = VOL_SHADING_LIGHT_VOLUME;
        if (b->st != OBS_STATUS_OK) {
            st = b->st;
            obs_error(ctx, b->st, "%s", b->msg);
        } else {
            lvp = &b->lv;
            sl = b->sl;
            set_num(ctx, &s->table, row, "l_rmse", b->l_rmse);
            set_num(ctx, &s->table, row, "l_mean_abs", b->l_mean_abs);
            set_num(ctx, &s->table, row, "l_max_abs", b->l_max_abs);
            set_num(ctx, &s->table, row, "l_mean_signed", b->l_mean_signed);
            set_num(ctx, &s->table, row, "l_voxels", b->l_voxels);
        }
    } else {
        rp.shading = !strcmp(method, "ea") ? VOL_SHADING_EMISSION_ABSORPTION : VOL_SHADING_PHONG;
    }
    /* run: the ray casting, `runs` times */
    for (int r = 0; r < s->o.runs && st == OBS_STATUS_OK; r++) {
        for (int q = 0; q < 4; q++)
            obs_image_f32_free(&img[q]);
        double t0 = obs_time_now();
        st = vol_raycast(ctx, pool, &f->grid, &f->tf, &f->light, lvp, &f->cam, s->W, s->H, NULL, &rp, img);
        t_rc[r] = 1e3 * (obs_time_now() - t0);
    }
    if (st == OBS_STATUS_OK) {
        study_stats sr = study_stats_of(t_rc, s->o.runs);
        set_num(ctx, &s->table, row, "rc_ms", sr.median);
        set_num(ctx, &s->table, row, "rc_ms_min", sr.min);
        set_num(ctx, &s->table, row, "rc_ms_max", sr.max);
        set_num(ctx, &s->table, row, "fixed_ms", sr.median);
        if (!isnan(sl.median)) {
            set_num(ctx, &s->table, row, "lv_ms", sl.median);
            set_num(ctx, &s->table, row, "lv_ms_min", sl.min);
            set_num(ctx, &s->table, row, "lv_ms_max", sl.max);
            set_num(ctx, &s->table, row, "scene_change_ms", sl.median + sr.median);
        }
    }
    /* error: the image against the MC reference (light-volume mode only: ea and phong are other
     * models), and the image cast with c = 1 */
    if (st == OBS_STATUS_OK && rp.shading == VOL_SHADING_LIGHT_VOLUME) {
        sv_img_err e = sv_image_error(img, &f->ref);
        set_num(ctx, &s->table, row, "img_rmse", e.rmse);
        set_num(ctx, &s->table, row, "img_rmse_nc", e.rmse_nc);
        set_num(ctx, &s->table, row, "img_bias", e.bias);
        set_num(ctx, &s->table, row, "img_rel_rmse", e.rel);
        set_num(ctx, &s->table, row, "ref_noise_rms", e.noise);
        set_num(ctx, &s->table, row, "pixels", (double)e.pixels);
        size_t nv = (size_t)lvp->nx * lvp->ny * lvp->nz;
        ones = (float *)malloc(nv * sizeof(float));
        if (!ones)
            st = obs_error(ctx, OBS_STATUS_OUT_OF_MEMORY, "study volume: out of memory");
        if (st == OBS_STATUS_OK) {
            for (size_t v = 0; v < nv; v++)
                ones[v] = 1.0f;
            vol_light_volume l1 = *lvp;
            l1.c[0] = l1.c[1] = l1.c[2] = ones;
            st = vol_raycast(ctx, pool, &f->grid, &f->tf, &f->light, &l1, &f->cam, s->W, s->H, NULL, &rp, img1);
        }
        if (st == OBS_STATUS_OK) {
            sv_img_err e1 = sv_image_error(img1, &f->ref);
            set_num(ctx, &s->table, row, "lonly_rmse", e1.rmse);
            set_num(ctx, &s->table, row, "lonly_rmse_nc", e1.rmse_nc);
            set_num(ctx, &s->table, row, "lonly_bias", e1.bias);
            set_num(ctx, &s->table, row, "lonly_rel_rmse", e1.rel);
        }
    }
    if (st == OBS_STATUS_OK) {
        set_str(ctx, &s->table, row, "status", "ok");
    } else {
        char msg[300];
        snprintf(msg, sizeof msg, "failed: %s", obs_context_last_error(ctx));
        for (char *p = msg; *p; p++)
            if (*p == '\n' || *p == '"')
                *p = ' ';
        set_str(ctx, &s->table, row, "status", msg);
        obs_context_clear_error(ctx);
        st = OBS_STATUS_OK; /* recorded, not retried */
    }
    for (int q = 0; q < 4; q++) {
        obs_image_f32_free(&img[q]);
        obs_image_f32_free(&img1[q]);
    }
    free(ones);
    free(t_rc);
    return st;
}

/* ================================================================================================
 * The sweep
 * ============================================================================================== */

static obs_status sv_save(obs_context *ctx, study_volume *s)
{
    obs_status st = io_make_dirs(ctx, s->o.out_dir);
    if (st == OBS_STATUS_OK)
        st = study_table_write_csv(ctx, &s->table, s->csv);
    if (st == OBS_STATUS_OK)
        st = study_table_write_json(ctx, &s->table, s->json);
    return st;
}

static obs_status sv_hybrid(obs_context *ctx, obs_pool *pool, study_volume *s); /* the hybrid stage, below */

obs_status study_volume_sweep(obs_context *ctx, obs_pool *pool, study_volume *s)
{
    if (!s)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "study volume: NULL study");
    const int threads = pool ? obs_pool_threads(pool) : 1;
    study_progress pr;
    study_progress_begin(&pr, s->o.log, study_volume_points(s, NULL));
    obs_status st = OBS_STATUS_OK;
    for (int di = 0; di < s->datasets.n && st == OBS_STATUS_OK; di++) {
        if (!s->present[di]) {
            if (s->o.log)
                fprintf(s->o.log, "obscura: study volume: skipping %s: %s\n", s->datasets.v[di], s->missing[di]);
            continue;
        }
        /* The dataset's keys; skip it whole when every one is measured. */
        const int nlv = s->scales.n * s->cones.n * s->blends.n;
        int pending = 0; /* points of this dataset not yet in the table */
        for (int k = 0; k < s->steps.n; k++) {
            for (int m = 0; m < nlv + 2; m++) {
                const char *key[6] = {s->datasets.v[di], "ea", "-", "-", "-", s->steps.v[k]};
                if (m == nlv + 1)
                    key[1] = "phong";
                else if (m < nlv) {
                    key[1] = "lightvolume";
                    key[2] = s->scales.v[m / (s->cones.n * s->blends.n)];
                    key[3] = s->cones.v[(m / s->blends.n) % s->cones.n];
                    key[4] = s->blends.v[m % s->blends.n];
                }
                pending += study_table_find(&s->table, key) < 0;
            }
        }
        if (!pending) {
            for (int k = 0; k < s->steps.n * (nlv + 2); k++)
                study_progress_step(&pr, 0, "resumed");
            continue;
        }
        sv_frame f;
        memset(&f, 0, sizeof f);
        st = sv_load(ctx, s, s->datasets.v[di], &f);
        if (st == OBS_STATUS_OK) {
            truth_volume_mc_params mp = truth_volume_mc_params_default();
            mp.samples = s->o.ref_samples;  /* a fixed count (docs/study.md: no adaptive stop) */
            mp.kappa = vol_lv_params_default().kappa;
            st = truth_volume_mc_render(ctx, pool, &f.grid, &f.tf, &f.light, &f.cam, s->W, s->H, &mp, &f.ref);
            f.ref_seconds = f.ref.stats.seconds;
            if (st == OBS_STATUS_OK && s->o.log)
                fprintf(s->o.log, "obscura: study volume: %s %dx%dx%d: MC reference %dx%d x %lld in %.1f s\n",
                        s->datasets.v[di], f.grid.nx, f.grid.ny, f.grid.nz, s->W, s->H, s->o.ref_samples,
                        f.ref_seconds);
        }
        /* configuration outer, step inner: a light volume is built once for all steps */
        for (int m = 0; m < nlv + 2 && st == OBS_STATUS_OK; m++) {
            sv_built built;
            int have_built = 0;
            for (int k = 0; k < s->steps.n && st == OBS_STATUS_OK; k++) {
                const char *key[6] = {s->datasets.v[di], "ea", "-", "-", "-", s->steps.v[k]};
                int si = -1;
                if (m == nlv + 1)
                    key[1] = "phong";
                else if (m < nlv) {
                    key[1] = "lightvolume";
                    si = m / (s->cones.n * s->blends.n);
                    key[2] = s->scales.v[si];
                    key[3] = s->cones.v[(m / s->blends.n) % s->cones.n];
                    key[4] = s->blends.v[m % s->blends.n];
                }
                char label[160];
                snprintf(label, sizeof label, "%s %s s%s c%s b%s h%s", key[0], key[1], key[2], key[3], key[4], key[5]);
                if (study_table_find(&s->table, key) >= 0) {
                    study_progress_step(&pr, 0, "resumed");
                    continue;
                }
                if (si >= 0 && !have_built) {
                    sv_build(ctx, pool, s, &f, key, si, &built);
                    have_built = 1;
                }
                st = sv_point(ctx, pool, s, &f, key, si >= 0 ? &built : NULL, threads);
                study_progress_step(&pr, 1, label);
            }
            if (have_built)
                vol_light_volume_free(&built.lv);
        }
        sv_frame_free(&f);
        obs_status sst = sv_save(ctx, s);
        if (st == OBS_STATUS_OK)
            st = sst;
    }
    study_progress_end(&pr);
    if (st == OBS_STATUS_OK)
        st = sv_hybrid(ctx, pool, s);
    obs_status sst = sv_save(ctx, s);
    return st != OBS_STATUS_OK ? st : sst;
}

/* ================================================================================================
 * The hybrid stage: the seed's Table 5.5
 * ============================================================================================== */

/* Mesh names and their scenes (mkdata): the dragon from dragon.glb; the bunny is the hybrid scene's
 * own (cornell_hybrid.glb, the Hebe statue's stand-in). */
static const char *const sv_hybrid_meshes[2] = {"dragon", "bunny"};

/* Put the largest mesh of donor (its first instance's placement dropped) where the bunny of the
 * hybrid scene stands: the same largest world extent, the same centre in x and z, on the floor
 * (lowest vertex at the bunny's lowest y). Its material stays the bunny's (marble SSS: the seed's
 * meshes scatter as in its Sec. 2.1). The donor's arrays move into s. */
static int sv_swap_bunny(obs_scene *s, obs_scene *donor)
{
    uint32_t bi = UINT32_MAX, dm = UINT32_MAX;
    for (uint32_t i = 0; i < s->instance_count; i++)
        if (!strncmp(s->meshes[s->instances[i].mesh].name, "bunny", 5))
            bi = i;
    for (uint32_t m = 0; m < donor->mesh_count; m++)
        if (dm == UINT32_MAX || donor->meshes[m].triangle_count > donor->meshes[dm].triangle_count)
            dm = m;
    if (bi == UINT32_MAX || dm == UINT32_MAX)
        return 0;
    obs_mesh *bm = &s->meshes[s->instances[bi].mesh], *nm = &donor->meshes[dm];
    float wlo[3] = {INFINITY, INFINITY, INFINITY}, whi[3] = {-INFINITY, -INFINITY, -INFINITY};
    float olo[3] = {INFINITY, INFINITY, INFINITY}, ohi[3] = {-INFINITY, -INFINITY, -INFINITY};
    for (uint32_t v = 0; v < bm->vertex_count; v++) {
        obs_vec3 p = obs_mat4_mul_point(s->instances[bi].world,
                                        obs_v3(bm->positions[3 * v], bm->positions[3 * v + 1], bm->positions[3 * v + 2]));
        float c[3] = {p.x, p.y, p.z};
        for (int a = 0; a < 3; a++) {
            wlo[a] = fminf(wlo[a], c[a]);
            whi[a] = fmaxf(whi[a], c[a]);
        }
    }
    for (uint32_t v = 0; v < nm->vertex_count; v++)
        for (int a = 0; a < 3; a++) {
            olo[a] = fminf(olo[a], nm->positions[3 * v + a]);
            ohi[a] = fmaxf(ohi[a], nm->positions[3 * v + a]);
        }
    float wext = fmaxf(whi[0] - wlo[0], fmaxf(whi[1] - wlo[1], whi[2] - wlo[2]));
    float oext = fmaxf(ohi[0] - olo[0], fmaxf(ohi[1] - olo[1], ohi[2] - olo[2]));
    if (!(oext > 0.0f))
        return 0;
    float k = wext / oext;
    obs_vec3 t = obs_v3(0.5f * (wlo[0] + whi[0]) - k * 0.5f * (olo[0] + ohi[0]), wlo[1] - k * olo[1],
                        0.5f * (wlo[2] + whi[2]) - k * 0.5f * (olo[2] + ohi[2]));
    s->instances[bi].world = obs_mat4_mul(obs_mat4_translation(t), obs_mat4_scale(obs_v3(k, k, k)));
    free(bm->positions);
    free(bm->normals);
    free(bm->indices);
    bm->positions = nm->positions;
    bm->normals = nm->normals;
    bm->indices = nm->indices;
    bm->vertex_count = nm->vertex_count;
    bm->triangle_count = nm->triangle_count;
    nm->positions = nm->normals = NULL;
    nm->indices = NULL;
    nm->vertex_count = nm->triangle_count = 0;
    snprintf(bm->name, sizeof bm->name, "hybrid_mesh");
    obs_scene_update_bounds(s);
    return 1;
}

static double sv_pass_ms(const render_frame *f, const char *name)
{
    for (int i = 0; i < f->pass_count; i++)
        if (!strcmp(f->passes[i].name, name))
            return 1e3 * f->passes[i].seconds;
    return NAN;
}

/* One pair: a fresh render_session (nothing cached), one cold frame (every pass runs: the light
 * volume is built), then `runs` frames in the same session (the view-independent products, the
 * light volume among them, reused: the fixed scene). Scene change = the cold frame's light_volume
 * pass + the fixed frame (Table 5.4's definition: rebuild the light volume, then draw). */
static obs_status sv_hybrid_pair(obs_context *ctx, int threads, study_volume *s, const char *volume, int mi)
{
    const study_volume_options *o = &s->o;
    const char *key[2] = {volume, sv_hybrid_meshes[mi]};
    const seed_hybrid_row *sd = NULL;
    for (int k = 0; k < SV_HYBRID_PAIRS; k++)
        if (!strcmp(study_volume_seed_hybrid[k].volume, key[0]) && !strcmp(study_volume_seed_hybrid[k].mesh, key[1]))
            sd = &study_volume_seed_hybrid[k];
    const char *vals[32] = {key[0], key[1]};
    obs_status st = study_table_append(ctx, &s->hybrid, vals);
    if (st != OBS_STATUS_OK)
        return st;
    const int64_t row = s->hybrid.rows - 1;
    set_num(ctx, &s->hybrid, row, "width", s->W);
    set_num(ctx, &s->hybrid, row, "height", s->H);
    set_num(ctx, &s->hybrid, row, "threads", threads);
    set_str(ctx, &s->hybrid, row, "seed_pair", sd ? sd->seed_pair : "");
    set_num(ctx, &s->hybrid, row, "seed_ms", sd ? sd->ms : NAN);
    if (!strcmp(volume, "cranium")) {
        char path[4200];
        snprintf(path, sizeof path, "%s/%s", o->volume_dir, dataset_file("cranium"));
        FILE *fp = fopen(path, "rb");
        if (!fp) {
            set_str(ctx, &s->hybrid, row, "status", "skipped: cranium.nrrd not found (scripts/fetch_volumes.sh)");
            return OBS_STATUS_OK;
        }
        fclose(fp);
    }
    obs_scene sc, donor;
    obs_scene_init(&sc);
    obs_scene_init(&donor);
    char path[4200];
    io_gltf_options go = io_gltf_options_default();
    snprintf(path, sizeof path, "%s/cornell_hybrid.glb", o->data_dir);
    st = io_gltf_load(ctx, path, &go, &sc);
    if (st == OBS_STATUS_OK && mi == 0) {
        snprintf(path, sizeof path, "%s/dragon.glb", o->data_dir);
        st = io_gltf_load(ctx, path, &go, &donor);
        if (st == OBS_STATUS_OK && !sv_swap_bunny(&sc, &donor))
            st = obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "study volume: no bunny in cornell_hybrid.glb or no mesh in %s",
                           path);
    }
    /* relative volume paths: from the working directory, as the study's other stages (the render
     * resolves them against the scene's directory unless the source has no slash) */
    snprintf(sc.source, sizeof sc.source, "cornell_hybrid.glb");
    render_settings rs = render_settings_default();
    if (st == OBS_STATUS_OK)
        st = render_settings_from_scene(ctx, &sc, &rs);
    if (st == OBS_STATUS_OK) {
        rs.width = s->W;
        rs.height = s->H;
        if (!strcmp(volume, "cranium")) {
            snprintf(rs.volume.source, sizeof rs.volume.source, "%s/%s", o->volume_dir, dataset_file("cranium"));
            snprintf(rs.volume.transfer, sizeof rs.volume.transfer, "%s", dataset_tf("cranium"));
        }
        if (o->quick) {
            /* CI-fast (ours): the maps at a few texels, as the render tests do */
            rs.shadow_map_size = 128;
            rs.sss.K = 4;
            rs.sss.N = 8;
            rs.sss.map_size = 48;
            rs.sss.light_map_size = 48;
            rs.volume.lv.scale = 4; /* the head CT's light volume at the data's size is ~13 s here */
        }
        st = render_settings_validate(ctx, &sc, &rs);
    }
    int64_t tris = 0;
    for (uint32_t i = 0; i < sc.instance_count; i++)
        if (!strcmp(sc.meshes[sc.instances[i].mesh].name, "hybrid_mesh") ||
            !strncmp(sc.meshes[sc.instances[i].mesh].name, "bunny", 5))
            tris = sc.meshes[sc.instances[i].mesh].triangle_count;
    set_num(ctx, &s->hybrid, row, "triangles", (double)tris);
    render_options ro = render_options_default();
    ro.threads = threads;
    render_session *rsn = st == OBS_STATUS_OK ? render_session_create(ctx, &ro) : NULL;
    if (st == OBS_STATUS_OK && !rsn)
        st = OBS_STATUS_OUT_OF_MEMORY;
    double *t = (double *)calloc((size_t)o->runs, sizeof(double));
    if (st == OBS_STATUS_OK && !t)
        st = obs_error(ctx, OBS_STATUS_OUT_OF_MEMORY, "study volume: out of memory (hybrid)");
    double lv_ms = NAN, cold_ms = NAN;
    if (st == OBS_STATUS_OK) {
        render_frame fr;
        memset(&fr, 0, sizeof fr);
        st = render_frame_run(rsn, &sc, &rs, 0, &fr);
        lv_ms = sv_pass_ms(&fr, "light_volume");
        cold_ms = 1e3 * fr.seconds;
        render_frame_free(&fr);
        for (int r = 0; r < o->runs && st == OBS_STATUS_OK; r++) {
            memset(&fr, 0, sizeof fr);
            st = render_frame_run(rsn, &sc, &rs, 0, &fr);
            t[r] = 1e3 * fr.seconds;
            render_frame_free(&fr);
        }
    }
    if (st == OBS_STATUS_OK) {
        study_stats ft = study_stats_of(t, o->runs);
        set_str(ctx, &s->hybrid, row, "status", "ok");
        set_num(ctx, &s->hybrid, row, "lv_ms", lv_ms);
        set_num(ctx, &s->hybrid, row, "cold_frame_ms", cold_ms);
        set_num(ctx, &s->hybrid, row, "frame_ms", ft.median);
        set_num(ctx, &s->hybrid, row, "frame_ms_min", ft.min);
        set_num(ctx, &s->hybrid, row, "frame_ms_max", ft.max);
        set_num(ctx, &s->hybrid, row, "fixed_ms", ft.median);
        set_num(ctx, &s->hybrid, row, "scene_change_ms", lv_ms + ft.median);
        if (o->log)
            fprintf(o->log, "obscura: study volume: hybrid %s + %s (%lld triangles): light volume %.2f ms, frame %.2f ms\n",
                    key[0], key[1], (long long)tris, lv_ms, ft.median);
    } else {
        char msg[300];
        snprintf(msg, sizeof msg, "error: %s", obs_context_last_error(ctx));
        set_str(ctx, &s->hybrid, row, "status", msg);
    }
    free(t);
    render_session_destroy(rsn);
    obs_scene_free(&sc);
    obs_scene_free(&donor);
    return st;
}

static obs_status sv_hybrid(obs_context *ctx, obs_pool *pool, study_volume *s)
{
    if (s->o.no_hybrid)
        return OBS_STATUS_OK;
    const int threads = pool ? obs_pool_threads(pool) : 1;
    static const char *const vols[2] = {"bucky", "cranium"};
    obs_status st = OBS_STATUS_OK;
    for (int v = 0; v < 2 && st == OBS_STATUS_OK; v++)
        for (int mi = 0; mi < 2 && st == OBS_STATUS_OK; mi++) {
            const char *key[2] = {vols[v], sv_hybrid_meshes[mi]};
            if (study_table_find(&s->hybrid, key) >= 0)
                continue;
            st = sv_hybrid_pair(ctx, threads, s, vols[v], mi);
        }
    obs_status sst = io_make_dirs(ctx, s->o.out_dir);
    if (sst == OBS_STATUS_OK)
        sst = study_table_write_csv(ctx, &s->hybrid, s->hcsv);
    return st != OBS_STATUS_OK ? st : sst;
}

/* ================================================================================================
 * The report
 * ============================================================================================== */

static double cell(const study_table *t, int64_t r, const char *col)
{
    return study_table_num(t, r, study_table_column(t, col));
}

static const char *scell(const study_table *t, int64_t r, const char *col)
{
    return study_table_get(t, r, study_table_column(t, col));
}

/* The row of (dataset, method) at the reference configuration: scale 1 (else the first), the cone
 * nearest 45 degrees, blend 1 (else 0), step 0.5 (else the first). -1 when none. */
static int64_t ref_row(const study_table *t, const char *dataset, const char *method)
{
    int64_t best = -1;
    double best_score = INFINITY;
    for (int64_t r = 0; r < t->rows; r++) {
        if (strcmp(scell(t, r, "dataset"), dataset) || strcmp(scell(t, r, "method"), method) ||
            strcmp(scell(t, r, "status"), "ok"))
            continue;
        double score = fabs(cell(t, r, "step") - 0.5) * 100.0;
        if (!strcmp(method, "lightvolume")) {
            score += fabs(cell(t, r, "scale") - 1.0) * 1000.0 + fabs(cell(t, r, "cone") - 45.0) +
                     (1.0 - cell(t, r, "blend")) * 10.0;
        }
        if (score < best_score) {
            best_score = score;
            best = r;
        }
    }
    return best;
}

static void fmt(char *buf, size_t n, double v, const char *f)
{
    if (isnan(v))
        snprintf(buf, n, "–");
    else
        snprintf(buf, n, f, v);
}

obs_status study_volume_report(obs_context *ctx, study_volume *s)
{
    if (!s || !s->o.report_dir)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "study volume: the report needs a report directory");
    obs_status st = io_make_dirs(ctx, s->o.report_dir);
    if (st != OBS_STATUS_OK)
        return st;
    const study_table *t = &s->table;
    char path[4400];
    snprintf(path, sizeof path, "%s/results.csv", s->o.report_dir);
    st = study_table_write_csv(ctx, t, path);
    if (st != OBS_STATUS_OK)
        return st;
    if (s->hybrid.rows > 0) {
        snprintf(path, sizeof path, "%s/hybrid.csv", s->o.report_dir);
        st = study_table_write_csv(ctx, &s->hybrid, path);
        if (st != OBS_STATUS_OK)
            return st;
    }

    /* The plot: image error (c = 1 part and full) against the scene-change time, a series per
     * dataset and scale. */
    {
        study_series ser[16];
        double *xs = (double *)calloc((size_t)t->rows * 16 + 1, sizeof(double));
        double *ys = (double *)calloc((size_t)t->rows * 16 + 1, sizeof(double));
        char names[16][96];
        int ns = 0;
        if (!xs || !ys) {
            free(xs);
            free(ys);
            return obs_error(ctx, OBS_STATUS_OUT_OF_MEMORY, "study volume: out of memory (report)");
        }
        for (int di = 0; di < s->datasets.n; di++)
            for (int si = 0; si < s->scales.n && ns < 16; si++) {
                int n = 0;
                double *x = xs + (size_t)ns * t->rows, *y = ys + (size_t)ns * t->rows;
                for (int64_t r = 0; r < t->rows; r++) {
                    if (strcmp(scell(t, r, "dataset"), s->datasets.v[di]) ||
                        strcmp(scell(t, r, "method"), "lightvolume") || strcmp(scell(t, r, "scale"), s->scales.v[si]) ||
                        strcmp(scell(t, r, "status"), "ok"))
                        continue;
                    x[n] = cell(t, r, "scene_change_ms");
                    y[n] = cell(t, r, "lonly_rmse_nc");
                    n++;
                }
                if (!n)
                    continue;
                snprintf(names[ns], sizeof names[ns], "%s, light volume 1/%s", s->datasets.v[di], s->scales.v[si]);
                ser[ns].name = names[ns];
                ser[ns].x = x;
                ser[ns].y = y;
                ser[ns].n = n;
                ns++;
            }
        if (ns > 0) {
            study_plot pl;
            memset(&pl, 0, sizeof pl);
            pl.title = "Light volume, shadows only (c = 1): image error against the Monte Carlo reference";
            pl.x_label = "scene change: light-volume build + ray casting (ms)";
            pl.y_label = "RMSE against MC, reference noise taken out";
            pl.log_x = 1;
            pl.log_y = 1;
            pl.pareto = 1;
            snprintf(path, sizeof path, "%s/error_vs_time.svg", s->o.report_dir);
            st = study_svg_scatter(ctx, path, &pl, ser, ns);
        }
        free(xs);
        free(ys);
        if (st != OBS_STATUS_OK)
            return st;
    }

    snprintf(path, sizeof path, "%s/README.md", s->o.report_dir);
    char tmp[4500];
    snprintf(tmp, sizeof tmp, "%s.tmp", path);
    FILE *fp = fopen(tmp, "w");
    if (!fp)
        return obs_error(ctx, OBS_STATUS_IO_ERROR, "study volume: cannot write %s", tmp);
    const study_volume_options *o = &s->o;
    fprintf(fp, "# Volume lighting study%s\n\n", o->quick ? " (reduced: `--quick`)" : "");
    fprintf(fp,
            "Generated by `obscura study volume%s` (src/study/study_volume.c; what each column means: "
            "docs/volume/truth.md, \"The study\"). Do not edit by hand.\n\n",
            o->quick ? " --quick" : "");
    if (o->command_line)
        fprintf(fp, "- Command: `%s` (rows already in its results.csv from earlier runs are kept: the tables may "
                    "hold points beyond these axes)\n",
                o->command_line);
    fprintf(fp,
            "- Axes: datasets `%s`, light-volume scales `%s` (1/s of the data per axis), cone angles `%s` degrees, "
            "dir_blend `%s`, ray-caster steps `%s` (x the smallest spacing); image %dx%d; %d timed run%s per stage "
            "(median).\n",
            o->datasets, o->scales, o->cones, o->blends, o->steps, s->W, s->H, o->runs, o->runs > 1 ? "s" : "");
    fprintf(fp,
            "- References: the light volume's l against the exact transmittance (trapezoid march, step %g x the "
            "smallest spacing) on a lattice of at most %lld voxels; the image against the Monte Carlo "
            "single-scattering reference (%lld samples per pixel, 8 replicates; its noise, the replicate s, "
            "is taken out of the RMSE). The light is directional, travelling along (0.4, -0.7, -0.6); the camera "
            "is `obscura volume`'s framing.\n",
            o->t_step, o->l_voxels, o->ref_samples);
    for (int di = 0; di < s->datasets.n; di++)
        if (!s->present[di])
            fprintf(fp, "- Dataset `%s` skipped: %s.\n", s->datasets.v[di], s->missing[di]);
    fprintf(fp,
            "- Times are on whatever machine ran the command, with whatever else ran on it (for this committed "
            "report: the shared 2-core development VM, other builds running): read them as orders of magnitude.\n\n");

    /* Table 1: the seed's layout */
    fprintf(fp, "## Time per frame, the seed's layout (its Table 5.4)\n\n");
    fprintf(fp,
            "Scene change = light-volume build + ray casting; fixed scene = ray casting with the light volume "
            "reused. Ours: scale 1, cone 45, dir_blend on, step 0.5 (or the nearest measured), CPU, %dx%d. The "
            "seed: GTX 660, 8 samples per fragment, light volume at the data's size; its bonsai and engine are not "
            "available offline, the head CT and the MRI stand in (issue 15).\n\n",
            s->W, s->H);
    fprintf(fp, "| dataset | voxels | light volume | scene change (ms) | fixed scene (ms) | emission-absorption (ms) | "
                "gradient Phong (ms) | seed: dataset | seed: scene change | seed: fixed |\n");
    fprintf(fp, "|---|---|---|---|---|---|---|---|---|---|\n");
    for (int di = 0; di < s->datasets.n; di++) {
        const char *d = s->datasets.v[di];
        int64_t rl = ref_row(t, d, "lightvolume"), re = ref_row(t, d, "ea"), rph = ref_row(t, d, "phong");
        if (rl < 0)
            continue;
        const seed_row *sd = NULL;
        for (size_t k = 0; k < sizeof study_volume_seed / sizeof study_volume_seed[0]; k++)
            if (!strcmp(study_volume_seed[k].ours, d))
                sd = &study_volume_seed[k];
        char a[32], b[32], c[32], e[32];
        fmt(a, sizeof a, cell(t, rl, "scene_change_ms"), "%.2f");
        fmt(b, sizeof b, cell(t, rl, "fixed_ms"), "%.2f");
        fmt(c, sizeof c, re >= 0 ? cell(t, re, "rc_ms") : NAN, "%.2f");
        fmt(e, sizeof e, rph >= 0 ? cell(t, rph, "rc_ms") : NAN, "%.2f");
        fprintf(fp, "| %s | %.0fx%.0fx%.0f | 1/%s, cone %s, blend %s, step %s | %s | %s | %s | %s | %s | %.2f | %.2f |\n",
                d, cell(t, rl, "nx"), cell(t, rl, "ny"), cell(t, rl, "nz"), scell(t, rl, "scale"), scell(t, rl, "cone"),
                scell(t, rl, "blend"), scell(t, rl, "step"), a, b, c, e, sd ? sd->seed_name : "–",
                sd ? sd->change_ms : NAN, sd ? sd->fixed_ms : NAN);
    }

    /* Table 1b: the hybrid scene, the seed's Table 5.5 */
    if (s->hybrid.rows > 0) {
        const study_table *h = &s->hybrid;
        fprintf(fp, "\n## Hybrid scene, the seed's layout (its Table 5.5)\n\n");
        fprintf(fp,
                "The bundled scene `cornell_hybrid.glb` (a Cornell box, an opaque block, a translucent mesh with "
                "marble SSS, the volume in a 1.2-unit box, one point light) rendered whole by `obscura render`'s "
                "pass graph (a render_session: G-buffer, shadow maps, AO, SSS, the light volume, the ray cast that "
                "stops at the mesh depth, the meshes shadowed through the light volume, the composition), %dx%d%s. "
                "Fixed scene = the median frame with the view-independent products (the light volume among them) "
                "reused; scene change = the light volume rebuilt (its pass in the first, uncached frame) + that "
                "frame. The seed: GTX 660, \"Rendering de la escena\", one figure per pair. Stand-ins (not "
                "available offline): the head CT for the bonsai, the Stanford bunny (our largest mesh) for the "
                "Hebe statue; the dragon is our 10,000-vertex Chinese dragon, not the Stanford one. Ours runs on "
                "the CPU; the seed's image size is not stated.\n\n",
                s->W, s->H,
                o->quick ? ", the shadow and SSS maps reduced and the light volume at 1/4 (`--quick`)" : "");
        fprintf(fp, "| volume | mesh (triangles) | ours: scene change (ms) | ours: fixed scene (ms) | seed: pair | "
                    "seed (ms) |\n");
        fprintf(fp, "|---|---|---|---|---|---|\n");
        for (int64_t r = 0; r < h->rows; r++) {
            char a[32], b[32], c[32];
            int ok = !strcmp(scell(h, r, "status"), "ok");
            fmt(a, sizeof a, ok ? cell(h, r, "scene_change_ms") : NAN, "%.2f");
            fmt(b, sizeof b, ok ? cell(h, r, "fixed_ms") : NAN, "%.2f");
            fmt(c, sizeof c, cell(h, r, "seed_ms"), "%.2f");
            fprintf(fp, "| %s | %s (%.0f) | %s | %s | %s | %s |%s%s\n", scell(h, r, "volume"), scell(h, r, "mesh"),
                    cell(h, r, "triangles"), a, b, scell(h, r, "seed_pair"), c, ok ? "" : " ",
                    ok ? "" : scell(h, r, "status"));
        }
        fprintf(fp, "\nThe rows: `hybrid.csv` (the cold frame, min and max too).\n");
    }

    /* Table 2: every light-volume point */
    fprintf(fp, "\n## Every light-volume point\n\n");
    fprintf(fp,
            "l: the light volume's transmittance against the exact one (RMSE, max |error|, mean signed: > 0 too "
            "bright). Image: RMSE of premultiplied RGB against the MC reference over the pixels either covers, "
            "the reference's noise taken out; *shadows only* casts the same light volume with its chromaticity "
            "c set to 1, the part with a ground truth; *full* keeps c (the cone-blurred chromaticity, which the "
            "reference does not model: its error includes that modelling difference). rel = RMSE / RMS of the "
            "reference.\n\n");
    fprintf(fp, "| dataset | scale | cone | blend | step | build (ms) | cast (ms) | l RMSE | l max | l mean signed | "
                "shadows only: RMSE | rel | full: RMSE | rel |\n");
    fprintf(fp, "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|\n");
    for (int64_t r = 0; r < t->rows; r++) {
        if (strcmp(scell(t, r, "method"), "lightvolume"))
            continue;
        if (strcmp(scell(t, r, "status"), "ok")) {
            fprintf(fp, "| %s | 1/%s | %s | %s | %s | %s |||||||||\n", scell(t, r, "dataset"), scell(t, r, "scale"),
                    scell(t, r, "cone"), scell(t, r, "blend"), scell(t, r, "step"), scell(t, r, "status"));
            continue;
        }
        fprintf(fp, "| %s | 1/%s | %s | %s | %s | %.2f | %.2f | %.4f | %.3f | %+.4f | %.4f | %.3f | %.4f | %.3f |\n",
                scell(t, r, "dataset"), scell(t, r, "scale"), scell(t, r, "cone"), scell(t, r, "blend"),
                scell(t, r, "step"), cell(t, r, "lv_ms"), cell(t, r, "rc_ms"), cell(t, r, "l_rmse"),
                cell(t, r, "l_max_abs"), cell(t, r, "l_mean_signed"), cell(t, r, "lonly_rmse_nc"),
                cell(t, r, "lonly_rel_rmse"), cell(t, r, "img_rmse_nc"), cell(t, r, "img_rel_rmse"));
    }
    fprintf(fp, "\n![error against time](error_vs_time.svg)\n\n");
    fprintf(fp, "The rows: `results.csv` (every column, the references' noise and cost included).\n");
    int bad = ferror(fp);
    bad |= fclose(fp) != 0;
    if (bad || rename(tmp, path) != 0) {
        remove(tmp);
        return obs_error(ctx, OBS_STATUS_IO_ERROR, "study volume: cannot write %s", path);
    }
    return OBS_STATUS_OK;
}
