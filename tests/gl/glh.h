/* glh.h: the project's headless GL harness. GLSL ports of every AO technique's reference shader
 * run here on Mesa's llvmpipe (EGL surfaceless platform, OpenGL 4.5 core), so that tests can check
 * our kernels against them number by number, and bench/gl_bench can time them beside ours.
 *
 * EGL and GL are loaded with dlopen at run time: nothing links against them, and the harness
 * compiles wherever <EGL/egl.h> and <GL/glcorearb.h> exist (GLH_AVAILABLE is 0 otherwise and
 * glh_open always fails with a reason).
 *
 * Rows: our images (obs_image_f32) have row 0 at the top; GL textures have row 0 at the bottom.
 * glh_texture_from_image and glh_read_image flip, so a pixel (x, y) of ours is texel
 * (x, H - 1 - y) in GL and gl_FragCoord = (x + 0.5, H - y - 0.5). A port that follows a D3D
 * shader (row 0 at the top, texture v down) uploads with GLH_ROWS_AS_IS and uses texUV.
 *
 * A port is a glh_run: a list of full-screen passes (program, input textures, target), drawn in
 * order. Uniforms are set once when the port is built (a program keeps them), so drawing a run
 * again costs only the passes themselves: that is what the benchmark times. */
#ifndef OBS_TESTS_GLH_H
#define OBS_TESTS_GLH_H

#include "core/obs.h"

#if defined(__has_include)
#if __has_include(<EGL/egl.h>) && __has_include(<GL/glcorearb.h>) && __has_include(<dlfcn.h>)
#define GLH_AVAILABLE 1
#endif
#endif
#ifndef GLH_AVAILABLE
#define GLH_AVAILABLE 0
#endif

#if GLH_AVAILABLE
#include <GL/glcorearb.h>
#else
typedef unsigned int GLuint;
typedef unsigned int GLenum;
typedef int GLint;
#endif

#include <stddef.h>

/* Every GL entry point the ports use; loaded with eglGetProcAddress. */
#define GLH_FUNCS(X)                                                                                  \
    X(PFNGLGETSTRINGPROC, glGetString) X(PFNGLGETERRORPROC, glGetError)                              \
    X(PFNGLCREATESHADERPROC, glCreateShader) X(PFNGLSHADERSOURCEPROC, glShaderSource)                \
    X(PFNGLCOMPILESHADERPROC, glCompileShader) X(PFNGLGETSHADERIVPROC, glGetShaderiv)                \
    X(PFNGLGETSHADERINFOLOGPROC, glGetShaderInfoLog) X(PFNGLDELETESHADERPROC, glDeleteShader)        \
    X(PFNGLCREATEPROGRAMPROC, glCreateProgram) X(PFNGLATTACHSHADERPROC, glAttachShader)              \
    X(PFNGLLINKPROGRAMPROC, glLinkProgram) X(PFNGLGETPROGRAMIVPROC, glGetProgramiv)                  \
    X(PFNGLGETPROGRAMINFOLOGPROC, glGetProgramInfoLog) X(PFNGLDELETEPROGRAMPROC, glDeleteProgram)    \
    X(PFNGLUSEPROGRAMPROC, glUseProgram) X(PFNGLGETUNIFORMLOCATIONPROC, glGetUniformLocation)        \
    X(PFNGLPROGRAMUNIFORM1FPROC, glProgramUniform1f) X(PFNGLPROGRAMUNIFORM2FPROC, glProgramUniform2f) \
    X(PFNGLPROGRAMUNIFORM3FPROC, glProgramUniform3f) X(PFNGLPROGRAMUNIFORM4FPROC, glProgramUniform4f) \
    X(PFNGLPROGRAMUNIFORM1IPROC, glProgramUniform1i) X(PFNGLPROGRAMUNIFORM2IPROC, glProgramUniform2i) \
    X(PFNGLPROGRAMUNIFORM1FVPROC, glProgramUniform1fv) X(PFNGLPROGRAMUNIFORM2FVPROC, glProgramUniform2fv) \
    X(PFNGLPROGRAMUNIFORM3FVPROC, glProgramUniform3fv) X(PFNGLPROGRAMUNIFORM4FVPROC, glProgramUniform4fv) \
    X(PFNGLPROGRAMUNIFORM1IVPROC, glProgramUniform1iv)                                               \
    X(PFNGLPROGRAMUNIFORMMATRIX4FVPROC, glProgramUniformMatrix4fv)                                   \
    X(PFNGLGENVERTEXARRAYSPROC, glGenVertexArrays) X(PFNGLBINDVERTEXARRAYPROC, glBindVertexArray)    \
    X(PFNGLDELETEVERTEXARRAYSPROC, glDeleteVertexArrays)                                             \
    X(PFNGLGENTEXTURESPROC, glGenTextures) X(PFNGLDELETETEXTURESPROC, glDeleteTextures)              \
    X(PFNGLBINDTEXTUREPROC, glBindTexture) X(PFNGLTEXIMAGE2DPROC, glTexImage2D)                      \
    X(PFNGLTEXSUBIMAGE2DPROC, glTexSubImage2D) X(PFNGLTEXSTORAGE2DPROC, glTexStorage2D)              \
    X(PFNGLTEXPARAMETERIPROC, glTexParameteri) X(PFNGLTEXPARAMETERFVPROC, glTexParameterfv)          \
    X(PFNGLGENFRAMEBUFFERSPROC, glGenFramebuffers) X(PFNGLDELETEFRAMEBUFFERSPROC, glDeleteFramebuffers) \
    X(PFNGLBINDFRAMEBUFFERPROC, glBindFramebuffer) X(PFNGLFRAMEBUFFERTEXTUREPROC, glFramebufferTexture) \
    X(PFNGLFRAMEBUFFERTEXTURE2DPROC, glFramebufferTexture2D)                                         \
    X(PFNGLCHECKFRAMEBUFFERSTATUSPROC, glCheckFramebufferStatus) X(PFNGLDRAWBUFFERSPROC, glDrawBuffers) \
    X(PFNGLREADBUFFERPROC, glReadBuffer) X(PFNGLVIEWPORTPROC, glViewport)                            \
    X(PFNGLACTIVETEXTUREPROC, glActiveTexture) X(PFNGLDRAWARRAYSPROC, glDrawArrays)                  \
    X(PFNGLREADPIXELSPROC, glReadPixels) X(PFNGLPIXELSTOREIPROC, glPixelStorei)                      \
    X(PFNGLFINISHPROC, glFinish) X(PFNGLENABLEPROC, glEnable) X(PFNGLDISABLEPROC, glDisable)         \
    X(PFNGLCLEARCOLORPROC, glClearColor) X(PFNGLCLEARPROC, glClear)                                  \
    X(PFNGLGETTEXIMAGEPROC, glGetTexImage) X(PFNGLBINDIMAGETEXTUREPROC, glBindImageTexture)          \
    X(PFNGLDISPATCHCOMPUTEPROC, glDispatchCompute) X(PFNGLMEMORYBARRIERPROC, glMemoryBarrier) \
    /* 3D render targets (glsl_volume.c: the light volume, one layer per slice) */                 \
    X(PFNGLTEXSTORAGE3DPROC, glTexStorage3D) X(PFNGLTEXSUBIMAGE3DPROC, glTexSubImage3D)              \
    X(PFNGLFRAMEBUFFERTEXTURELAYERPROC, glFramebufferTextureLayer) X(PFNGLTEXTUREBARRIERPROC, glTextureBarrier)

#if GLH_AVAILABLE
#define GLH_DECL(T, n) T n;
typedef struct glh_gl {
    GLH_FUNCS(GLH_DECL)
} glh_gl;
#undef GLH_DECL
#else
typedef struct glh_gl {
    int unused;
} glh_gl;
#endif

/* An open harness: a current GL 4.5 core context on llvmpipe. */
typedef struct glh {
    glh_gl gl;
    const char *renderer, *version;
    void *lib, *dpy, *ctx; /* the EGL library handle, display and context */
    GLuint vao;           /* the empty vertex array the full-screen triangle draws from */
} glh;

/* Open the harness on llvmpipe. Returns 1, or 0 with the reason in why (no libEGL, no surfaceless
 * display, no GL 4.5 core context, a renderer that is not llvmpipe, or a sanitizer build where
 * GLH_ALLOW_SANITIZERS is not set; see glh.c). */
int glh_open(glh *g, char *why, size_t why_size);
void glh_close(glh *g);

/* For tests: open the harness or leave the test. Where llvmpipe is unavailable the test prints why
 * and exits 77 (ctest: skipped); under CI=true a skipped GL test fails instead (exit 1), because
 * these tests are the proof that GPU ports agree with us (issue 13). */
void glh_open_or_skip(glh *g);

/* The vertex shader every pass uses: one full-screen triangle (gl_VertexID 0..2). It passes
 * texCoord (GL: v up, (0,0) at the bottom-left) and texUV (D3D: v down). */
extern const char *const glh_fullscreen_vs;

/* Compile and link glh_fullscreen_vs with fs, inserting prelude (e.g. "#define TAPS 11\n") right
 * after fs's #version line. Returns 0 and prints the log on failure. */
GLuint glh_program(glh *g, const char *fs, const char *prelude);
/* A compute program (fs replaced by a compute shader), same rules. */
GLuint glh_compute_program(glh *g, const char *cs, const char *prelude);

/* Uniform setters on a program (silently ignore names the compiler dropped, as GL does). */
void glh_set1f(glh *g, GLuint p, const char *name, float v);
void glh_set2f(glh *g, GLuint p, const char *name, float a, float b);
void glh_set3f(glh *g, GLuint p, const char *name, float a, float b, float c);
void glh_set4f(glh *g, GLuint p, const char *name, float a, float b, float c, float d);
void glh_set1i(glh *g, GLuint p, const char *name, int v);
void glh_set2i(glh *g, GLuint p, const char *name, int a, int b);
void glh_setfv(glh *g, GLuint p, const char *name, int comps, int count, const float *v);

enum { GLH_ROWS_FLIP = 0, GLH_ROWS_AS_IS = 1 };

/* A 2D float texture of w x h with `levels` MIP levels (storage only above level 0) and internal
 * format ifmt (GL_R32F, GL_RG32F, GL_RGBA32F, ...); data (comps floats per texel, row 0 first in
 * the given order; NULL = uninitialised) fills level 0. filter: GL_NEAREST or GL_LINEAR (min and
 * mag; with levels > 1, min uses GL_NEAREST_MIPMAP_NEAREST); wrap: GL_CLAMP_TO_EDGE,
 * GL_CLAMP_TO_BORDER (border 0), GL_REPEAT. */
GLuint glh_texture(glh *g, int w, int h, int levels, GLenum ifmt, int comps, const float *data, int rows,
                   GLenum filter, GLenum wrap);
/* One of our planes as an R32F texture (rows flipped or not); non-finite values replaced by
 * `background` when background is finite (ports document why). */
GLuint glh_texture_from_image(glh *g, const obs_image_f32 *im, int rows, float background, GLenum filter,
                              GLenum wrap);
/* A framebuffer drawing into level `level` of tex. */
GLuint glh_framebuffer(glh *g, GLuint tex, int level);

/* One full-screen pass: program, input textures on units 0..ntex-1, target framebuffer of w x h.
 * A pass with groups_x > 0 is a compute dispatch instead (images bound by the port's own code). */
typedef struct glh_pass {
    GLuint prog, fbo;
    int w, h;
    GLuint tex[8];
    int ntex;
    const char *name; /* for the benchmark and logs */
} glh_pass;

#define GLH_MAX_PASSES 48
#define GLH_MAX_OBJECTS 96
typedef struct glh_run {
    glh_pass pass[GLH_MAX_PASSES];
    int npass;
    int nkernel;            /* passes [0, nkernel) are the AO kernel; the rest are the blur */
    GLuint out_fbo;         /* where the result is read from: R channel of this framebuffer */
    int out_w, out_h, out_rows; /* its size, and GLH_ROWS_FLIP or GLH_ROWS_AS_IS */
    GLuint textures[GLH_MAX_OBJECTS], fbos[GLH_MAX_OBJECTS], progs[GLH_MAX_OBJECTS];
    int ntextures, nfbos, nprogs; /* owned objects, deleted by glh_run_free */
} glh_run;

/* Record owned objects (returns the object, 0 if the table is full or obj is 0). */
GLuint glh_run_own_texture(glh_run *r, GLuint t);
GLuint glh_run_own_fbo(glh_run *r, GLuint f);
GLuint glh_run_own_program(glh_run *r, GLuint p);
/* Append a pass; returns its index, or -1 when full. */
int glh_run_add(glh_run *r, const char *name, GLuint prog, GLuint fbo, int w, int h, int ntex, const GLuint *tex);

/* Draw passes [first, first + count) (no glFinish). */
void glh_run_draw(glh *g, const glh_run *r, int first, int count);
/* Read the result's red channel into a fresh w x h image (rows in our order). */
obs_status glh_run_read(glh *g, const glh_run *r, obs_context *ctx, obs_image_f32 *out);
void glh_run_free(glh *g, glh_run *r);

/* Milliseconds for draw + glFinish of passes [first, first + count), best of nothing: one run. */
double glh_run_time_ms(glh *g, const glh_run *r, int first, int count);

/* |a - b| over pixels where mask (if non-NULL) is finite and > 0: median, p99, max, count over tol. */
typedef struct glh_diff {
    int n, over;
    double median, p99, max;
} glh_diff;
glh_diff glh_compare(const obs_image_f32 *a, const obs_image_f32 *b, const obs_image_f32 *mask, float tol);

#endif
