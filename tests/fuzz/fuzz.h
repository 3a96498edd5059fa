/* fuzz.h: the fuzz targets' entry functions and their shared helpers.
 *
 * Each target is a plain function `int obs_fuzz_<target>(const uint8_t *data, size_t size)`
 * compiled into two programs:
 *   - the libFuzzer binary fuzz_<target> (OBS_FUZZ=ON, clang-14), whose LLVMFuzzerTestOneInput
 *     calls it (libfuzzer_main.c);
 *   - obscura_fuzz_replay (every build with tests), which ctest runs over the committed seed
 *     corpus and every regression reproducer (replay.c).
 * A target returns 0. It aborts (a finding) when a documented invariant breaks, e.g. a loader
 * that reports success with an inconsistent scene, or one that fails and leaves data behind. */
#ifndef OBS_FUZZ_H
#define OBS_FUZZ_H

#include "core/obs.h"

#include <stddef.h>
#include <stdint.h>

int obs_fuzz_gltf(const uint8_t *data, size_t size);
int obs_fuzz_exr(const uint8_t *data, size_t size);
int obs_fuzz_off(const uint8_t *data, size_t size);
int obs_fuzz_cli_args(const uint8_t *data, size_t size);
int obs_fuzz_json(const uint8_t *data, size_t size);
int obs_fuzz_render_settings(const uint8_t *data, size_t size);
int obs_fuzz_gbuffer(const uint8_t *data, size_t size);

/* A context that logs nothing (warnings about hostile files would flood the fuzzer's output),
 * with limits small enough that one input cannot ask for gigabytes: the limits themselves are
 * under test (a refusal is a normal outcome), not the machine's memory. */
obs_context *fuzz_context(void);

/* abort() with a message when cond is false: an invariant of the code under test broke. */
void fuzz_require(int cond, const char *what);

#endif
