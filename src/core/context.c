/* context.c: status strings, the per-caller context (first error kept, logging), limits,
 * overflow-checked size arithmetic. */
#include "obs.h"

#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

struct obs_context {
    obs_status status;        /* first error since the last clear */
    char message[1024];
    obs_error_fn error_fn;
    void *error_user;
    obs_log_fn log_fn;
    void *log_user;
    obs_log_level level;
    obs_limits limits;
    struct {
        const void *key;
        void *obj;
        void (*destroy)(void *);
    } scratch[OBS_CONTEXT_SCRATCH_SLOTS]; /* obs_context_scratch_put: parked scratch objects */
};

const char *obs_status_string(obs_status s)
{
    switch (s) {
    case OBS_STATUS_OK: return "ok";
    case OBS_STATUS_INVALID_ARGUMENT: return "invalid argument";
    case OBS_STATUS_OUT_OF_MEMORY: return "out of memory";
    case OBS_STATUS_LIMIT_EXCEEDED: return "limit exceeded";
    case OBS_STATUS_IO_ERROR: return "I/O error";
    case OBS_STATUS_PARSE_ERROR: return "parse error";
    case OBS_STATUS_UNSUPPORTED: return "unsupported";
    case OBS_STATUS_UNSUPPORTED_ISA: return "unsupported instruction set";
    case OBS_STATUS_INVALID_DEPTH_RANGE: return "invalid depth range";
    case OBS_STATUS_NOT_FOUND: return "not found";
    case OBS_STATUS_INTERNAL: return "internal error";
    default: return "unknown status";
    }
}

/* Defaults. Each is a documented limit (docs/reliability.md) that a CLI flag raises. */
obs_limits obs_limits_default(void)
{
    obs_limits l;
    l.max_image_pixels = (int64_t)1 << 28;           /* 16384 x 16384: RAST_MAX_DIM squared */
    l.max_triangles = (int64_t)1 << 28;
    l.max_vertices = (int64_t)1 << 28;
    l.max_memory_bytes = (int64_t)16 << 30;          /* 16 GiB, below this machine's 24 GiB */
    l.max_samples = (int64_t)1 << 20;
    l.max_voxels = (int64_t)1 << 31;
    return l;
}

obs_context *obs_context_create(void)
{
    obs_context *c = (obs_context *)calloc(1, sizeof *c);
    if (!c)
        return NULL;
    c->level = OBS_LOG_WARN;
    c->limits = obs_limits_default();
    return c;
}

void obs_context_destroy(obs_context *ctx)
{
    obs_context_scratch_release(ctx);
    free(ctx);
}

void *obs_context_scratch_take(obs_context *ctx, const void *key)
{
    if (!ctx)
        return NULL;
    for (int i = 0; i < OBS_CONTEXT_SCRATCH_SLOTS; i++)
        if (ctx->scratch[i].obj && ctx->scratch[i].key == key) {
            void *obj = ctx->scratch[i].obj;
            ctx->scratch[i].obj = NULL;
            ctx->scratch[i].key = NULL;
            return obj;
        }
    return NULL;
}

void obs_context_scratch_put(obs_context *ctx, const void *key, void *obj, void (*destroy)(void *))
{
    if (!obj)
        return;
    if (ctx) {
        int free_slot = -1, taken = 0;
        for (int i = 0; i < OBS_CONTEXT_SCRATCH_SLOTS; i++) {
            if (ctx->scratch[i].obj && ctx->scratch[i].key == key)
                taken = 1; /* one object per key: keep the parked one */
            else if (!ctx->scratch[i].obj && free_slot < 0)
                free_slot = i;
        }
        if (!taken && free_slot >= 0) {
            ctx->scratch[free_slot].key = key;
            ctx->scratch[free_slot].obj = obj;
            ctx->scratch[free_slot].destroy = destroy;
            return;
        }
    }
    destroy(obj);
}

void obs_context_scratch_release(obs_context *ctx)
{
    if (!ctx)
        return;
    for (int i = 0; i < OBS_CONTEXT_SCRATCH_SLOTS; i++)
        if (ctx->scratch[i].obj) {
            ctx->scratch[i].destroy(ctx->scratch[i].obj);
            ctx->scratch[i].obj = NULL;
            ctx->scratch[i].key = NULL;
        }
}

obs_status obs_error(obs_context *ctx, obs_status status, const char *fmt, ...)
{
    char msg[1024];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(msg, sizeof msg, fmt, ap);
    va_end(ap);
    if (!ctx)
        return status;
    if (ctx->status == OBS_STATUS_OK && status != OBS_STATUS_OK) {
        ctx->status = status;
        memcpy(ctx->message, msg, sizeof msg);
    }
    if (ctx->error_fn)
        ctx->error_fn(ctx->error_user, status, msg);
    return status;
}

const char *obs_context_last_error(const obs_context *ctx) { return ctx ? ctx->message : ""; }
obs_status obs_context_last_status(const obs_context *ctx) { return ctx ? ctx->status : OBS_STATUS_OK; }

void obs_context_clear_error(obs_context *ctx)
{
    if (!ctx)
        return;
    ctx->status = OBS_STATUS_OK;
    ctx->message[0] = '\0';
}

void obs_context_set_error_callback(obs_context *ctx, obs_error_fn fn, void *user)
{
    ctx->error_fn = fn;
    ctx->error_user = user;
}

void obs_context_set_log_level(obs_context *ctx, obs_log_level level) { ctx->level = level; }
obs_log_level obs_context_log_level(const obs_context *ctx) { return ctx ? ctx->level : OBS_LOG_WARN; }

void obs_context_set_log_callback(obs_context *ctx, obs_log_fn fn, void *user)
{
    ctx->log_fn = fn;
    ctx->log_user = user;
}

void obs_log(obs_context *ctx, obs_log_level level, const char *fmt, ...)
{
    obs_log_level max = ctx ? ctx->level : OBS_LOG_WARN;
    if (level > max)
        return;
    char msg[1024];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(msg, sizeof msg, fmt, ap);
    va_end(ap);
    if (ctx && ctx->log_fn) {
        ctx->log_fn(ctx->log_user, level, msg);
        return;
    }
    static const char *names[] = {"error", "warning", "info", "debug"};
    fprintf(stderr, "obscura: %s: %s\n", names[level < OBS_LOG_COUNT ? level : 0], msg);
}

const obs_limits *obs_context_limits(const obs_context *ctx)
{
    static const obs_limits *defaults_ptr;
    static obs_limits defaults;
    if (ctx)
        return &ctx->limits;
    if (!defaults_ptr) {
        defaults = obs_limits_default();
        defaults_ptr = &defaults;
    }
    return defaults_ptr;
}

void obs_context_set_limits(obs_context *ctx, const obs_limits *limits) { ctx->limits = *limits; }

int obs_mul_size(size_t a, size_t b, size_t *out)
{
    if (a != 0 && b > SIZE_MAX / a)
        return 0;
    *out = a * b;
    return 1;
}

int obs_add_size(size_t a, size_t b, size_t *out)
{
    if (b > SIZE_MAX - a)
        return 0;
    *out = a + b;
    return 1;
}
