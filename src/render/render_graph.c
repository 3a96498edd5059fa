/* render_graph.c: the passes in their order, and the compile step: walk back from the requested
 * outputs and cull every pass whose products nobody reads (the frame graph's dead-code
 * elimination [ODonnell17], ../shared/reference/render.md section 1), recording why each pass is
 * in or out. The order is fixed (producers before readers), so the walk back is one reverse pass:
 * a pass is live when the scene calls for it and a live reader (or a requested output) needs one
 * of its writes; its reads then become needed. A pass the scene does not call for is culled with
 * the scene's reason even when an output would read it (its readers treat the input as absent). */
#include "render_internal.h"

#include <stdio.h>
#include <string.h>

static const char *const res_names[RES_COUNT_BITS] = {
    "gbuffer", "shadow_maps", "direct", "ao", "ambient", "sss_light_maps", "sss_maps", "sss",
    "volume_grid", "light_volume", "volume", "beauty", "ref_scene", "ref_ao", "ref_ambient", "ref_sss",
    "ref_volume", "ref_beauty"};

const char *render_resource_name(unsigned bit)
{
    for (int i = 0; i < RES_COUNT_BITS; i++)
        if (bit == (1u << i))
            return res_names[i];
    return "?";
}

/* The passes in execution order: producers before readers (the light volume before direct: the
 * volume shadows the meshes, docs/render.md "Composition"). */
static const render_pass *const passes[] = {
    &render_pass_gbuffer,     &render_pass_shadow_maps, &render_pass_volume_load, &render_pass_light_volume,
    &render_pass_direct,      &render_pass_ao,          &render_pass_ambient,     &render_pass_sss_light_maps,
    &render_pass_sss_maps,    &render_pass_sss_combine, &render_pass_raycast,     &render_pass_compose,
    &render_pass_ref_scene,  &render_pass_ref_ao,      &render_pass_ref_ambient, &render_pass_ref_sss,
    &render_pass_ref_volume, &render_pass_ref_compose,
};

const render_pass *const *render_passes(int *count)
{
    *count = (int)(sizeof passes / sizeof passes[0]);
    return passes;
}

/* The layer bits to the resources that hold them. */
static unsigned requested_resources(const render_settings *st)
{
    unsigned r = 0, o = st->outputs;
    if (o & RENDER_OUT_BEAUTY) r |= RES_BEAUTY | (st->reference ? RES_REF_BEAUTY : 0);
    if (o & RENDER_OUT_DIRECT) r |= RES_DIRECT;
    if (o & RENDER_OUT_AMBIENT) r |= RES_AMBIENT | (st->reference ? RES_REF_AMBIENT : 0);
    if (o & RENDER_OUT_AO) r |= RES_AO | (st->reference ? RES_REF_AO : 0);
    if (o & RENDER_OUT_SSS) r |= RES_SSS | (st->reference ? RES_REF_SSS : 0);
    if (o & RENDER_OUT_VOLUME) r |= RES_VOLUME | (st->reference ? RES_REF_VOLUME : 0);
    if (o & (RENDER_OUT_DEPTH | RENDER_OUT_NORMAL | RENDER_OUT_ALBEDO)) r |= RES_GBUFFER;
    return r;
}

static void names_of(unsigned bits, char *out, size_t size)
{
    out[0] = '\0';
    for (int i = 0; i < RES_COUNT_BITS; i++)
        if (bits & (1u << i)) {
            size_t n = strlen(out);
            snprintf(out + n, size - n, "%s%s", n ? "," : "", res_names[i]);
        }
}

/* Which requested layers the pass's outputs would have fed, for the culling reason. */
static void culled_reason(unsigned writes, const render_settings *st, char *out, size_t size)
{
    char w[96];
    names_of(writes, w, sizeof w);
    const int beauty = (st->outputs & RENDER_OUT_BEAUTY) != 0;
    const int layer = (writes & (RES_DIRECT | RES_AO | RES_AMBIENT | RES_SSS | RES_VOLUME | RES_REF_AO |
                                 RES_REF_AMBIENT | RES_REF_SSS | RES_REF_VOLUME)) != 0;
    if (layer)
        snprintf(out, size, "output '%s' not requested%s", w, beauty ? " and no requested output reads it"
                                                                      : " and beauty not requested");
    else
        snprintf(out, size, "no requested output reads '%s'", w);
}

obs_status render_graph_compile(render_job *j, int live[], int order[])
{
    int count;
    const render_pass *const *ps = render_passes(&count);
    render_frame *f = j->f;
    unsigned need = requested_resources(j->st), produced = 0;
    char reason[RENDER_MAX_PASSES][224], reads[RENDER_MAX_PASSES][192];
    unsigned rmask[RENDER_MAX_PASSES];
    for (int i = count - 1; i >= 0; i--) {
        const render_pass *p = ps[i];
        live[i] = 0;
        rmask[i] = p->reads(j, reads[i], sizeof reads[i]);
        if (p->is_reference && !j->st->reference) {
            snprintf(reason[i], sizeof reason[i], "reference off (--reference not given)");
            continue;
        }
        int wanted = p->wanted(j, reason[i], sizeof reason[i]);
        if (!wanted)
            continue;
        if (!(p->writes & need)) {
            culled_reason(p->writes, j->st, reason[i], sizeof reason[i]);
            continue;
        }
        live[i] = 1;
        need |= rmask[i];
        produced |= p->writes;
    }
    /* The records: live passes in execution order, then the culled ones. */
    int n = 0;
    for (int pass = 0; pass < 2; pass++)
        for (int i = 0; i < count; i++) {
            if (live[i] != (pass == 0))
                continue;
            render_pass_record *r = &f->passes[n];
            memset(r, 0, sizeof *r);
            snprintf(r->name, sizeof r->name, "%s", ps[i]->name);
            memcpy(r->reads, reads[i], sizeof r->reads);
            r->reads[sizeof r->reads - 1] = '\0';
            names_of(ps[i]->writes, r->writes, sizeof r->writes);
            memcpy(r->reason, reason[i], sizeof r->reason);
            r->reason[sizeof r->reason - 1] = '\0';
            r->view_dependent = ps[i]->view_dependent;
            r->state = live[i] ? RENDER_PASS_PLANNED : RENDER_PASS_CULLED;
            order[n++] = i;
        }
    f->pass_count = n;
    /* The layers this frame will hold. */
    unsigned out = 0, o = j->st->outputs;
    if ((o & RENDER_OUT_BEAUTY) && (produced & RES_BEAUTY)) out |= RENDER_OUT_BEAUTY;
    if ((o & RENDER_OUT_DIRECT) && (produced & RES_DIRECT)) out |= RENDER_OUT_DIRECT;
    if ((o & RENDER_OUT_AMBIENT) && (produced & RES_AMBIENT)) out |= RENDER_OUT_AMBIENT;
    if ((o & RENDER_OUT_AO) && (produced & RES_AO)) out |= RENDER_OUT_AO;
    if ((o & RENDER_OUT_SSS) && (produced & RES_SSS)) out |= RENDER_OUT_SSS;
    if ((o & RENDER_OUT_VOLUME) && (produced & RES_VOLUME)) out |= RENDER_OUT_VOLUME;
    if (produced & RES_GBUFFER)
        out |= o & (RENDER_OUT_DEPTH | RENDER_OUT_NORMAL | RENDER_OUT_ALBEDO);
    f->outputs = out;
    return OBS_STATUS_OK;
}
