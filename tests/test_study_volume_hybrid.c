/* The volume study's hybrid stage (src/study/study_volume.c; docs/volume/truth.md, "The study"):
 * the quick study renders the bundled hybrid scene for (bucky | cranium) x (dragon | bunny),
 * records finite positive times for the four pairs, resumes them, and writes the report's section
 * with the seed's Table 5.5 beside ours. */
#include "test.h"

#include "core/obs.h"
#include "study/study_volume.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

TEST(study_volume_hybrid_stage_times_four_pairs_beside_the_seeds_table)
{
    obs_context *ctx = obs_context_create();
    obs_pool *pool = obs_pool_create(2);
    const char *dir = test_tmpdir();
    char report[4096], vols[4096];
    snprintf(report, sizeof report, "%s/report", dir);
    snprintf(vols, sizeof vols, "%s/data/cache/volumes", test_source_dir());
    study_volume_options o = study_volume_options_quick();
    o.out_dir = dir;
    o.report_dir = report;
    o.volume_dir = vols;
    o.size = "32x32";
    o.ref_samples = 64;
    o.scales = "4";
    o.blends = "1";
    study_volume *s = NULL;
    CHECK_OK(study_volume_open(ctx, &o, &s), ctx);
    CHECK_OK(study_volume_sweep(ctx, pool, s), ctx);
    const study_table *h = study_volume_hybrid_table(s);
    CHECK_EQ_INT(h->rows, 4);
    int bunny_tris = 0, dragon_tris = 0;
    for (int64_t r = 0; r < h->rows; r++) {
        const char *st = study_table_get(h, r, study_table_column(h, "status"));
        CHECK_MSG(!strcmp(st, "ok"), "row %lld: %s", (long long)r, st);
        double fixed = study_table_num(h, r, study_table_column(h, "fixed_ms"));
        double change = study_table_num(h, r, study_table_column(h, "scene_change_ms"));
        double lv = study_table_num(h, r, study_table_column(h, "lv_ms"));
        CHECK(isfinite(fixed) && fixed > 0.0 && isfinite(lv) && lv > 0.0);
        CHECK_NEAR(change, fixed + lv, 1e-6 * change);
        const char *mesh = study_table_get(h, r, study_table_column(h, "mesh"));
        int tris = (int)study_table_num(h, r, study_table_column(h, "triangles"));
        if (!strcmp(mesh, "bunny"))
            bunny_tris = tris;
        else
            dragon_tris = tris;
        printf("%s + %s (%d triangles): scene change %.2f ms, fixed %.2f ms\n",
               study_table_get(h, r, study_table_column(h, "volume")), mesh, tris, change, fixed);
    }
    /* the bunny (the Hebe statue's stand-in) is the larger mesh, as Hebe is the seed's */
    CHECK(bunny_tris > dragon_tris && dragon_tris > 0);
    CHECK_OK(study_volume_report(ctx, s), ctx);
    char *md = test_slurp(test_path(report, "README.md"), NULL);
    CHECK(md && strstr(md, "## Hybrid scene, the seed's layout (its Table 5.5)"));
    CHECK(md && strstr(md, "## Time per frame, the seed's layout (its Table 5.4)"));
    static const char *const seed[4] = {"| 12.63 |", "| 5.73 |", "| 13.62 |", "| 5.07 |"};
    for (int k = 0; k < 4 && md; k++)
        CHECK_MSG(strstr(md, seed[k]) != NULL, "the seed's %s is not in the report", seed[k]);
    free(md);
    char *csv = test_slurp(test_path(report, "hybrid.csv"), NULL);
    CHECK(csv && strstr(csv, "volume,mesh,"));
    free(csv);
    study_volume_close(s);
    /* resume: the four pairs are read back from hybrid.csv, nothing is rendered again */
    s = NULL;
    CHECK_OK(study_volume_open(ctx, &o, &s), ctx);
    CHECK_EQ_INT(study_volume_hybrid_table(s)->rows, 4);
    double t0 = obs_time_now();
    CHECK_OK(study_volume_sweep(ctx, pool, s), ctx);
    CHECK_EQ_INT(study_volume_hybrid_table(s)->rows, 4);
    CHECK(obs_time_now() - t0 < 0.5);
    study_volume_close(s);
    obs_pool_destroy(pool);
    obs_context_destroy(ctx);
}
