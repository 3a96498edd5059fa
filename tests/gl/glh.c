/* glh.c: the headless GL harness (glh.h). EGL 1.5 on Mesa's surfaceless platform, as Mesa's own
 * documentation and ../shared/tools/llvmpipe-peer describe it; libEGL is opened with dlopen. */
#define _GNU_SOURCE
#include "glh.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

const char *const glh_fullscreen_vs =
    "#version 450\n"
    "out vec2 texCoord; out vec2 texUV;\n"
    "void main(){ vec2 p = vec2((gl_VertexID << 1) & 2, gl_VertexID & 2);\n"
    "  gl_Position = vec4(p * 2.0 - 1.0, 0.0, 1.0); texCoord = p; texUV = vec2(p.x, 1.0 - p.y); }\n";

static void set_why(char *why, size_t n, const char *msg, const char *arg)
{
    if (why && n)
        snprintf(why, n, msg, arg ? arg : "");
}

void glh_open_or_skip(glh *g)
{
    char why[512];
    if (glh_open(g, why, sizeof why)) {
        printf("  GL: %s, %s\n", g->renderer, g->version);
        fflush(stdout);
        return;
    }
    const char *ci = getenv("CI");
    if (ci && !strcmp(ci, "true")) {
        printf("  FAIL: llvmpipe unavailable under CI=true (%s); scripts/setup.sh installs EGL and Mesa\n", why);
        fflush(stdout);
        exit(1);
    }
    printf("  llvmpipe unavailable, skipping: %s\n", why);
    fflush(stdout);
    exit(77); /* ctest: skipped (SKIP_RETURN_CODE in tests/CMakeLists.txt) */
}

#if !GLH_AVAILABLE

int glh_open(glh *g, char *why, size_t n)
{
    memset(g, 0, sizeof *g);
    set_why(why, n, "built without <EGL/egl.h> and <GL/glcorearb.h> (libegl-dev, libgl-dev)%s", "");
    return 0;
}
void glh_close(glh *g) { (void)g; }

#else

#include <EGL/egl.h>
#include <EGL/eglext.h>
#include <dlfcn.h>

typedef struct glh_egl {
    PFNEGLGETPROCADDRESSPROC gpa;
    PFNEGLGETPLATFORMDISPLAYPROC getdpy;
    PFNEGLINITIALIZEPROC init;
    PFNEGLBINDAPIPROC bind;
    PFNEGLCHOOSECONFIGPROC choose;
    PFNEGLCREATECONTEXTPROC create;
    PFNEGLMAKECURRENTPROC current;
    PFNEGLDESTROYCONTEXTPROC destroy;
    PFNEGLTERMINATEPROC term;
} glh_egl;

static int load_egl(void *lib, glh_egl *e)
{
    e->gpa = (PFNEGLGETPROCADDRESSPROC)dlsym(lib, "eglGetProcAddress");
    e->getdpy = e->gpa ? (PFNEGLGETPLATFORMDISPLAYPROC)e->gpa("eglGetPlatformDisplay") : NULL;
    e->init = (PFNEGLINITIALIZEPROC)dlsym(lib, "eglInitialize");
    e->bind = (PFNEGLBINDAPIPROC)dlsym(lib, "eglBindAPI");
    e->choose = (PFNEGLCHOOSECONFIGPROC)dlsym(lib, "eglChooseConfig");
    e->create = (PFNEGLCREATECONTEXTPROC)dlsym(lib, "eglCreateContext");
    e->current = (PFNEGLMAKECURRENTPROC)dlsym(lib, "eglMakeCurrent");
    e->destroy = (PFNEGLDESTROYCONTEXTPROC)dlsym(lib, "eglDestroyContext");
    e->term = (PFNEGLTERMINATEPROC)dlsym(lib, "eglTerminate");
    return e->getdpy && e->init && e->bind && e->choose && e->create && e->current && e->destroy && e->term;
}

int glh_open(glh *g, char *why, size_t n)
{
    memset(g, 0, sizeof *g);
    /* llvmpipe, whatever hardware the machine has: the ports are compared on Mesa's software
     * rasterizer, whose float arithmetic is IEEE single precision (no fast-math, no FMA contraction
     * by default in its LLVM JIT). */
    setenv("LIBGL_ALWAYS_SOFTWARE", "1", 0);
    setenv("GALLIUM_DRIVER", "llvmpipe", 0);
    setenv("EGL_PLATFORM", "surfaceless", 0);
    void *lib = dlopen("libEGL.so.1", RTLD_NOW | RTLD_LOCAL);
    if (!lib) {
        set_why(why, n, "no libEGL.so.1 (%s)", dlerror());
        return 0;
    }
    glh_egl e;
    if (!load_egl(lib, &e)) {
        set_why(why, n, "EGL 1.5 entry points missing%s", "");
        dlclose(lib);
        return 0;
    }
    EGLDisplay dpy = e.getdpy(EGL_PLATFORM_SURFACELESS_MESA, EGL_DEFAULT_DISPLAY, NULL);
    if (dpy == EGL_NO_DISPLAY || !e.init(dpy, NULL, NULL)) {
        set_why(why, n, "no surfaceless EGL display (Mesa's libegl-mesa0 missing?)%s", "");
        dlclose(lib);
        return 0;
    }
    e.bind(EGL_OPENGL_API);
    const EGLint ca[] = {EGL_SURFACE_TYPE, EGL_PBUFFER_BIT, EGL_RENDERABLE_TYPE, EGL_OPENGL_BIT, EGL_NONE};
    const EGLint xa[] = {EGL_CONTEXT_MAJOR_VERSION, 4, EGL_CONTEXT_MINOR_VERSION, 5,
                         EGL_CONTEXT_OPENGL_PROFILE_MASK, EGL_CONTEXT_OPENGL_CORE_PROFILE_BIT, EGL_NONE};
    EGLint nc = 0;
    EGLConfig cfg;
    EGLContext ctx = EGL_NO_CONTEXT;
    if (e.choose(dpy, ca, &cfg, 1, &nc) && nc > 0)
        ctx = e.create(dpy, cfg, EGL_NO_CONTEXT, xa);
    if (ctx == EGL_NO_CONTEXT || !e.current(dpy, EGL_NO_SURFACE, EGL_NO_SURFACE, ctx)) {
        set_why(why, n, "no OpenGL 4.5 core context%s", "");
        if (ctx != EGL_NO_CONTEXT)
            e.destroy(dpy, ctx);
        e.term(dpy);
        dlclose(lib);
        return 0;
    }
    int have = 1;
#define GLH_LOAD(T, name) have = have && (g->gl.name = (T)e.gpa(#name)) != NULL;
    GLH_FUNCS(GLH_LOAD)
#undef GLH_LOAD
    g->lib = lib;
    g->dpy = dpy;
    g->ctx = ctx;
    g->renderer = have ? (const char *)g->gl.glGetString(GL_RENDERER) : NULL;
    g->version = have ? (const char *)g->gl.glGetString(GL_VERSION) : NULL;
    if (!have || !g->renderer || !strstr(g->renderer, "llvmpipe")) {
        set_why(why, n, "the renderer is %s, not llvmpipe", have && g->renderer ? g->renderer : "(none)");
        glh_close(g);
        return 0;
    }
    g->gl.glGenVertexArrays(1, &g->vao);
    g->gl.glBindVertexArray(g->vao);
    g->gl.glPixelStorei(GL_PACK_ALIGNMENT, 1);
    g->gl.glPixelStorei(GL_UNPACK_ALIGNMENT, 1);
    return 1;
}

void glh_close(glh *g)
{
    if (!g->lib)
        return;
    glh_egl e;
    load_egl(g->lib, &e);
    if (g->vao && g->gl.glDeleteVertexArrays)
        g->gl.glDeleteVertexArrays(1, &g->vao);
    if (g->ctx) {
        e.current(g->dpy, EGL_NO_SURFACE, EGL_NO_SURFACE, EGL_NO_CONTEXT);
        e.destroy(g->dpy, g->ctx);
    }
    /* The display stays initialised and libEGL loaded: eglTerminate unloads Mesa's driver, and
     * LeakSanitizer then reports the driver's few remaining allocations (112 bytes, Mesa 22.3.6)
     * against an "<unknown module>" that no suppression can name. Left loaded, the driver's
     * allocations stay reachable; the process ends soon after in every use (tests, benchmark). */
    memset(g, 0, sizeof *g);
}

/* fs with prelude inserted after its first line (#version) */
static char *with_prelude(const char *src, const char *prelude)
{
    const char *nl = strchr(src, '\n');
    size_t head = nl ? (size_t)(nl - src) + 1 : 0, lp = prelude ? strlen(prelude) : 0, ls = strlen(src);
    char *s = malloc(ls + lp + 2);
    if (!s)
        return NULL;
    memcpy(s, src, head);
    if (lp)
        memcpy(s + head, prelude, lp);
    memcpy(s + head + lp, src + head, ls - head + 1);
    return s;
}

static GLuint compile(glh *g, GLenum type, const char *src, const char *prelude)
{
    char *s = with_prelude(src, prelude);
    if (!s)
        return 0;
    GLuint sh = g->gl.glCreateShader(type);
    const char *cs = s;
    g->gl.glShaderSource(sh, 1, &cs, NULL);
    g->gl.glCompileShader(sh);
    free(s);
    GLint ok = 0;
    g->gl.glGetShaderiv(sh, GL_COMPILE_STATUS, &ok);
    if (!ok) {
        char log[4096];
        g->gl.glGetShaderInfoLog(sh, sizeof log, NULL, log);
        printf("  GLSL compile error: %s\n", log);
        g->gl.glDeleteShader(sh);
        return 0;
    }
    return sh;
}

static GLuint link(glh *g, GLuint a, GLuint b)
{
    if (!a || (b == 0 && a == 0))
        return 0;
    GLuint p = g->gl.glCreateProgram();
    g->gl.glAttachShader(p, a);
    if (b)
        g->gl.glAttachShader(p, b);
    g->gl.glLinkProgram(p);
    g->gl.glDeleteShader(a);
    if (b)
        g->gl.glDeleteShader(b);
    GLint ok = 0;
    g->gl.glGetProgramiv(p, GL_LINK_STATUS, &ok);
    if (!ok) {
        char log[4096];
        g->gl.glGetProgramInfoLog(p, sizeof log, NULL, log);
        printf("  GLSL link error: %s\n", log);
        g->gl.glDeleteProgram(p);
        return 0;
    }
    return p;
}

GLuint glh_program(glh *g, const char *fs, const char *prelude)
{
    GLuint v = compile(g, GL_VERTEX_SHADER, glh_fullscreen_vs, NULL);
    GLuint f = v ? compile(g, GL_FRAGMENT_SHADER, fs, prelude) : 0;
    if (!f) {
        if (v)
            g->gl.glDeleteShader(v);
        return 0;
    }
    return link(g, v, f);
}

GLuint glh_compute_program(glh *g, const char *cs, const char *prelude)
{
    GLuint c = compile(g, GL_COMPUTE_SHADER, cs, prelude);
    return c ? link(g, c, 0) : 0;
}

#define LOC(name) g->gl.glGetUniformLocation(p, name)
void glh_set1f(glh *g, GLuint p, const char *name, float v) { g->gl.glProgramUniform1f(p, LOC(name), v); }
void glh_set2f(glh *g, GLuint p, const char *name, float a, float b) { g->gl.glProgramUniform2f(p, LOC(name), a, b); }
void glh_set3f(glh *g, GLuint p, const char *name, float a, float b, float c)
{
    g->gl.glProgramUniform3f(p, LOC(name), a, b, c);
}
void glh_set4f(glh *g, GLuint p, const char *name, float a, float b, float c, float d)
{
    g->gl.glProgramUniform4f(p, LOC(name), a, b, c, d);
}
void glh_set1i(glh *g, GLuint p, const char *name, int v) { g->gl.glProgramUniform1i(p, LOC(name), v); }
void glh_set2i(glh *g, GLuint p, const char *name, int a, int b) { g->gl.glProgramUniform2i(p, LOC(name), a, b); }
void glh_setfv(glh *g, GLuint p, const char *name, int comps, int count, const float *v)
{
    const GLint l = LOC(name);
    switch (comps) {
    case 1: g->gl.glProgramUniform1fv(p, l, count, v); break;
    case 2: g->gl.glProgramUniform2fv(p, l, count, v); break;
    case 3: g->gl.glProgramUniform3fv(p, l, count, v); break;
    default: g->gl.glProgramUniform4fv(p, l, count, v); break;
    }
}
#undef LOC

static GLenum format_of(int comps)
{
    return comps == 1 ? GL_RED : comps == 2 ? GL_RG : comps == 3 ? GL_RGB : GL_RGBA;
}

GLuint glh_texture(glh *g, int w, int h, int levels, GLenum ifmt, int comps, const float *data, int rows,
                   GLenum filter, GLenum wrap)
{
    GLuint t = 0;
    g->gl.glGenTextures(1, &t);
    g->gl.glBindTexture(GL_TEXTURE_2D, t);
    g->gl.glTexStorage2D(GL_TEXTURE_2D, levels < 1 ? 1 : levels, ifmt, w, h);
    if (data) {
        if (rows == GLH_ROWS_FLIP) {
            const size_t row = (size_t)w * (size_t)comps;
            for (int y = 0; y < h; y++)
                g->gl.glTexSubImage2D(GL_TEXTURE_2D, 0, 0, h - 1 - y, w, 1, format_of(comps), GL_FLOAT,
                                      data + (size_t)y * row);
        } else {
            g->gl.glTexSubImage2D(GL_TEXTURE_2D, 0, 0, 0, w, h, format_of(comps), GL_FLOAT, data);
        }
    }
    const GLenum minf = levels > 1 ? (filter == GL_LINEAR ? GL_LINEAR_MIPMAP_NEAREST : GL_NEAREST_MIPMAP_NEAREST)
                                   : filter;
    g->gl.glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, (GLint)minf);
    g->gl.glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, (GLint)filter);
    g->gl.glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_S, (GLint)wrap);
    g->gl.glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_T, (GLint)wrap);
    g->gl.glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAX_LEVEL, (levels < 1 ? 1 : levels) - 1);
    if (wrap == GL_CLAMP_TO_BORDER) {
        const float zero[4] = {0, 0, 0, 0};
        g->gl.glTexParameterfv(GL_TEXTURE_2D, GL_TEXTURE_BORDER_COLOR, zero);
    }
    return t;
}

GLuint glh_texture_from_image(glh *g, const obs_image_f32 *im, int rows, float background, GLenum filter,
                              GLenum wrap)
{
    const int w = im->width, h = im->height;
    float *buf = malloc(sizeof(float) * (size_t)w * (size_t)h);
    if (!buf)
        return 0;
    for (int y = 0; y < h; y++) {
        const float *s = obs_image_f32_row(im, y);
        float *d = buf + (size_t)y * (size_t)w;
        for (int x = 0; x < w; x++)
            d[x] = (isfinite(background) && !isfinite(s[x])) ? background : s[x];
    }
    GLuint t = glh_texture(g, w, h, 1, GL_R32F, 1, buf, rows, filter, wrap);
    free(buf);
    return t;
}

GLuint glh_framebuffer(glh *g, GLuint tex, int level)
{
    GLuint f = 0;
    g->gl.glGenFramebuffers(1, &f);
    g->gl.glBindFramebuffer(GL_FRAMEBUFFER, f);
    g->gl.glFramebufferTexture(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, tex, level);
    const GLenum db = GL_COLOR_ATTACHMENT0;
    g->gl.glDrawBuffers(1, &db);
    if (g->gl.glCheckFramebufferStatus(GL_FRAMEBUFFER) != GL_FRAMEBUFFER_COMPLETE) {
        printf("  GL: framebuffer on texture %u level %d is incomplete\n", tex, level);
        g->gl.glDeleteFramebuffers(1, &f);
        return 0;
    }
    return f;
}

#endif /* GLH_AVAILABLE */

/* ---- runs (plain bookkeeping; GL calls only when GLH_AVAILABLE) ---- */

static GLuint own(GLuint *tab, int *n, GLuint obj)
{
    if (!obj || *n >= GLH_MAX_OBJECTS)
        return 0;
    tab[(*n)++] = obj;
    return obj;
}
GLuint glh_run_own_texture(glh_run *r, GLuint t) { return own(r->textures, &r->ntextures, t); }
GLuint glh_run_own_fbo(glh_run *r, GLuint f) { return own(r->fbos, &r->nfbos, f); }
GLuint glh_run_own_program(glh_run *r, GLuint p) { return own(r->progs, &r->nprogs, p); }

int glh_run_add(glh_run *r, const char *name, GLuint prog, GLuint fbo, int w, int h, int ntex, const GLuint *tex)
{
    if (r->npass >= GLH_MAX_PASSES || ntex < 0 || ntex > 8)
        return -1;
    glh_pass *p = &r->pass[r->npass];
    memset(p, 0, sizeof *p);
    p->name = name;
    p->prog = prog;
    p->fbo = fbo;
    p->w = w;
    p->h = h;
    p->ntex = ntex;
    for (int i = 0; i < ntex; i++)
        p->tex[i] = tex[i];
    return r->npass++;
}

#if GLH_AVAILABLE
void glh_run_draw(glh *g, const glh_run *r, int first, int count)
{
    for (int i = first; i < first + count && i < r->npass; i++) {
        const glh_pass *p = &r->pass[i];
        g->gl.glUseProgram(p->prog);
        for (int t = 0; t < p->ntex; t++) {
            g->gl.glActiveTexture(GL_TEXTURE0 + (GLenum)t);
            g->gl.glBindTexture(GL_TEXTURE_2D, p->tex[t]);
        }
        g->gl.glBindFramebuffer(GL_FRAMEBUFFER, p->fbo);
        g->gl.glViewport(0, 0, p->w, p->h);
        g->gl.glDrawArrays(GL_TRIANGLES, 0, 3);
    }
}

obs_status glh_run_read(glh *g, const glh_run *r, obs_context *ctx, obs_image_f32 *out)
{
    const int w = r->out_w, h = r->out_h;
    obs_status st = obs_image_f32_alloc(ctx, w, h, out);
    if (st != OBS_STATUS_OK)
        return st;
    float *buf = malloc(sizeof(float) * (size_t)w * (size_t)h);
    if (!buf) {
        obs_image_f32_free(out);
        return OBS_STATUS_OUT_OF_MEMORY;
    }
    g->gl.glBindFramebuffer(GL_FRAMEBUFFER, r->out_fbo);
    g->gl.glReadBuffer(GL_COLOR_ATTACHMENT0);
    g->gl.glReadPixels(0, 0, w, h, GL_RED, GL_FLOAT, buf);
    g->gl.glFinish();
    for (int y = 0; y < h; y++) {
        const int gy = r->out_rows == GLH_ROWS_FLIP ? h - 1 - y : y;
        memcpy(obs_image_f32_row(out, y), buf + (size_t)gy * (size_t)w, sizeof(float) * (size_t)w);
    }
    free(buf);
    return OBS_STATUS_OK;
}

void glh_run_free(glh *g, glh_run *r)
{
    if (r->nfbos)
        g->gl.glDeleteFramebuffers(r->nfbos, r->fbos);
    if (r->ntextures)
        g->gl.glDeleteTextures(r->ntextures, r->textures);
    for (int i = 0; i < r->nprogs; i++)
        g->gl.glDeleteProgram(r->progs[i]);
    memset(r, 0, sizeof *r);
}

double glh_run_time_ms(glh *g, const glh_run *r, int first, int count)
{
    struct timespec a, b;
    g->gl.glFinish();
    clock_gettime(CLOCK_MONOTONIC, &a);
    glh_run_draw(g, r, first, count);
    g->gl.glFinish();
    clock_gettime(CLOCK_MONOTONIC, &b);
    return (double)(b.tv_sec - a.tv_sec) * 1e3 + (double)(b.tv_nsec - a.tv_nsec) * 1e-6;
}
#else
void glh_run_draw(glh *g, const glh_run *r, int first, int count) { (void)g, (void)r, (void)first, (void)count; }
obs_status glh_run_read(glh *g, const glh_run *r, obs_context *ctx, obs_image_f32 *out)
{
    (void)g, (void)r, (void)ctx, (void)out;
    return OBS_STATUS_UNSUPPORTED;
}
void glh_run_free(glh *g, glh_run *r) { (void)g, memset(r, 0, sizeof *r); }
double glh_run_time_ms(glh *g, const glh_run *r, int first, int count)
{
    (void)g, (void)r, (void)first, (void)count;
    return 0.0;
}
#endif

static int cmp_float(const void *a, const void *b)
{
    const float x = *(const float *)a, y = *(const float *)b;
    return x < y ? -1 : x > y;
}

glh_diff glh_compare(const obs_image_f32 *a, const obs_image_f32 *b, const obs_image_f32 *mask, float tol)
{
    glh_diff d = {0, 0, 0.0, 0.0, 0.0};
    const int w = a->width, h = a->height;
    if (b->width != w || b->height != h)
        return d;
    float *e = malloc(sizeof(float) * (size_t)w * (size_t)h);
    if (!e)
        return d;
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++) {
            if (mask) {
                const float m = obs_image_f32_row(mask, y)[x];
                if (!(isfinite(m) && m > 0.0f))
                    continue;
            }
            const float va = obs_image_f32_row(a, y)[x], vb = obs_image_f32_row(b, y)[x];
            /* a NaN on either side counts as an infinite difference */
            const float v = (va == va && vb == vb) ? fabsf(va - vb) : INFINITY;
            e[d.n++] = v;
            d.over += v > tol;
        }
    if (d.n) {
        qsort(e, (size_t)d.n, sizeof(float), cmp_float);
        d.median = e[d.n / 2];
        d.p99 = e[(int)(0.99 * (d.n - 1))];
        d.max = e[d.n - 1];
    }
    free(e);
    return d;
}
