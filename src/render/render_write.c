/* render_write.c: the pass log table, the layered EXR, the beauty PNG and the JSON sidecar
 * (docs/render.md, "Files"). Every file is written atomically (io_exr_write, io_png_write and
 * io_json_write write a temporary file and rename it). */
#include "render_internal.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "../io/io.h"

void render_pass_log_print(FILE *out, const render_frame *f)
{
    if (!out || !f)
        return;
    fprintf(out, "  %-15s %-8s %9s  %s\n", "pass", "state", "ms", "reason");
    for (int i = 0; i < f->pass_count; i++) {
        const render_pass_record *r = &f->passes[i];
        char ms[32] = "-";
        if (r->state != RENDER_PASS_CULLED && r->state != RENDER_PASS_PLANNED)
            snprintf(ms, sizeof ms, "%.1f", 1e3 * r->seconds);
        fprintf(out, "  %-15s %-8s %9s  %s\n", r->name, render_pass_state_name(r->state), ms, r->reason);
    }
}

/* One layer's channels: "NAME.R", "NAME.G", ... */
typedef struct chan_list {
    io_channel ch[64];
    char names[64][32];
    int n;
} chan_list;

static void add_layer(chan_list *L, const char *layer, const obs_image_f32 *planes, int count, const char *const *suffix)
{
    if (!planes[0].data)
        return;
    for (int c = 0; c < count && L->n < 64; c++) {
        snprintf(L->names[L->n], sizeof L->names[L->n], "%s.%s", layer, suffix[c]);
        L->ch[L->n].name = L->names[L->n];
        L->ch[L->n].type = IO_PIXEL_FLOAT;
        L->ch[L->n].f32 = &planes[c];
        L->ch[L->n].u32 = NULL;
        L->n++;
    }
}

static const char *const RGB[3] = {"R", "G", "B"};
static const char *const RGBA[4] = {"R", "G", "B", "A"};
static const char *const XYZ[3] = {"X", "Y", "Z"};
static const char *const Y1[1] = {"Y"};
static const char *const Z1[1] = {"Z"};

static void layers_of(const render_frame *f, chan_list *L)
{
    L->n = 0;
    add_layer(L, "beauty", f->beauty, 3, RGB);
    add_layer(L, "direct", f->direct, 3, RGB);
    add_layer(L, "ambient", f->ambient, 3, RGB);
    add_layer(L, "ao", &f->ao, 1, Y1);
    add_layer(L, "sss", f->sss, 3, RGB);
    add_layer(L, "volume", f->volume, 4, RGBA);
    add_layer(L, "depth", &f->depth, 1, Z1);
    add_layer(L, "normal", f->normal, 3, XYZ);
    add_layer(L, "albedo", f->albedo, 3, RGB);
    add_layer(L, "ref_beauty", f->ref_beauty, 3, RGB);
    add_layer(L, "ref_ambient", f->ref_ambient, 3, RGB);
    add_layer(L, "ref_ao", &f->ref_ao, 1, Y1);
    add_layer(L, "ref_sss", f->ref_sss, 3, RGB);
    add_layer(L, "ref_volume", f->ref_volume, 4, RGBA);
}

static void json_camera(io_json *j, const render_frame *f)
{
    io_json_begin_object(j, "camera");
    io_json_int(j, "index", f->camera);
    io_json_string(j, "name", f->cam.name);
    io_json_string(j, "projection", f->cam.projection == OBS_PROJECTION_PERSPECTIVE ? "perspective" : "orthographic");
    io_json_number(j, "yfov", f->cam.yfov);
    io_json_number(j, "aspect", f->cam.aspect);
    io_json_number(j, "xmag", f->cam.xmag);
    io_json_number(j, "ymag", f->cam.ymag);
    io_json_number(j, "znear", f->cam.znear);
    if (isfinite(f->cam.zfar))
        io_json_number(j, "zfar", f->cam.zfar);
    else
        io_json_string(j, "zfar", "infinity");
    io_json_floats(j, "world", f->cam.world.m, 16);
    io_json_end_object(j);
}

static void json_passes(io_json *j, const render_frame *f)
{
    io_json_begin_array(j, "passes");
    for (int i = 0; i < f->pass_count; i++) {
        const render_pass_record *r = &f->passes[i];
        io_json_begin_object(j, NULL);
        io_json_string(j, "name", r->name);
        io_json_string(j, "state", render_pass_state_name(r->state));
        io_json_string(j, "reason", r->reason);
        io_json_string(j, "reads", r->reads);
        io_json_string(j, "writes", r->writes);
        io_json_bool(j, "view_dependent", r->view_dependent);
        if (r->key[0])
            io_json_string(j, "key", r->key);
        io_json_number(j, "seconds", r->seconds);
        io_json_int(j, "output_bytes", (int64_t)r->output_bytes);
        io_json_int(j, "peak_rss_bytes", (int64_t)r->peak_rss_bytes);
        io_json_end_object(j);
    }
    io_json_end_array(j);
}

static void json_reference(io_json *j, const render_frame *f)
{
    io_json_begin_object(j, "reference");
    io_json_number(j, "seconds_approximation", f->seconds_approx);
    io_json_number(j, "seconds_reference", f->seconds_reference);
    io_json_begin_array(j, "errors");
    for (int i = 0; i < f->error_count; i++) {
        const render_layer_error *e = &f->errors[i];
        io_json_begin_object(j, NULL);
        io_json_string(j, "layer", e->layer);
        io_json_number(j, "rmse", e->rmse);
        io_json_number(j, "mae", e->mae);
        io_json_number(j, "bias", e->bias);
        io_json_number(j, "psnr", e->psnr);
        io_json_int(j, "pixels", e->pixels);
        io_json_end_object(j);
    }
    io_json_end_array(j);
    io_json_end_object(j);
}

obs_status render_frame_write(obs_context *ctx, const render_frame *f, const obs_scene *scene,
                              const render_settings *st, const char *prefix, int argc, char **argv)
{
    if (!f || !prefix || !st)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "render_frame_write: NULL argument");
    char path[4200];
    if (strlen(prefix) > 4000)
        return obs_error(ctx, OBS_STATUS_INVALID_ARGUMENT, "render_frame_write: prefix too long");
    chan_list *L = (chan_list *)calloc(1, sizeof *L);
    if (!L)
        return obs_error(ctx, OBS_STATUS_OUT_OF_MEMORY, "render_frame_write: out of memory");
    layers_of(f, L);
    obs_status r = OBS_STATUS_OK;
    io_attr at[3];
    memset(at, 0, sizeof at);
    snprintf(at[0].name, sizeof at[0].name, "obscura:version");
    at[0].type = IO_ATTR_STRING;
    at[0].s = (char *)OBS_VERSION_STRING;
    snprintf(at[1].name, sizeof at[1].name, "obscura:input");
    at[1].type = IO_ATTR_STRING;
    at[1].s = (char *)(scene ? scene->source : "");
    snprintf(at[2].name, sizeof at[2].name, "obscura:conventions");
    at[2].type = IO_ATTR_STRING;
    at[2].s = (char *)"radiance in the lights' units (docs/render.md); volume premultiplied RGBA; depth.Z linear "
                      "view depth, inf = background; normal.XYZ view space facing the viewer; row 0 at top";
    if (L->n > 0) {
        snprintf(path, sizeof path, "%s.exr", prefix);
        r = io_exr_write(ctx, path, L->ch, L->n, at, 3);
    }
    free(L);
    if (r == OBS_STATUS_OK && f->beauty[0].data) {
        snprintf(path, sizeof path, "%s.png", prefix);
        r = io_png_write(ctx, path, f->beauty, 3, IO_PNG_SRGB);
    }
    if (r != OBS_STATUS_OK)
        return r;
    io_json j;
    io_json_init(&j);
    io_json_begin_object(&j, NULL);
    io_json_string(&j, "generator", "obscura");
    io_json_string(&j, "version", OBS_VERSION_STRING);
    io_json_string(&j, "command", "render");
    io_json_begin_array(&j, "argv");
    for (int i = 0; argv && i < argc; i++)
        io_json_string(&j, NULL, argv[i]);
    io_json_end_array(&j);
    io_json_string(&j, "scene", scene ? scene->source : "");
    io_json_int(&j, "width", f->width);
    io_json_int(&j, "height", f->height);
    json_camera(&j, f);
    render_settings_to_json(st, &j);
    io_json_begin_array(&j, "layers");
    for (unsigned b = 1; b & RENDER_OUT_ALL; b <<= 1)
        if (f->outputs & b)
            io_json_string(&j, NULL, render_output_name(b));
    io_json_end_array(&j);
    io_json_number(&j, "seconds", f->seconds);
    json_passes(&j, f);
    {   /* this frame's view-independent products: built, or from the memory or disk cache */
        int64_t n[RENDER_PASS_STATE_COUNT] = {0};
        for (int i = 0; i < f->pass_count; i++)
            if (!f->passes[i].view_dependent && (unsigned)f->passes[i].state < RENDER_PASS_STATE_COUNT)
                n[f->passes[i].state]++;
        io_json_begin_object(&j, "cache");
        io_json_int(&j, "built", n[RENDER_PASS_RAN]);
        io_json_int(&j, "hits_memory", n[RENDER_PASS_CACHED_MEMORY]);
        io_json_int(&j, "hits_disk", n[RENDER_PASS_CACHED_DISK]);
        io_json_end_object(&j);
    }
    if (f->has_reference)
        json_reference(&j, f);
    io_json_string(&j, "png", "beauty, sRGB-encoded, clamped to [0, 1]");
    io_json_end_object(&j);
    snprintf(path, sizeof path, "%s.json", prefix);
    r = io_json_write(ctx, &j, path);
    io_json_free(&j);
    return r;
}
