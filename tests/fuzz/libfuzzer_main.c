/* libfuzzer_main.c: the libFuzzer entry of one fuzz target, compiled once per target with
 * OBS_FUZZ_ENTRY set to its obs_fuzz_<target> function (tests/fuzz/CMakeLists.txt). */
#include "fuzz.h"

#ifndef OBS_FUZZ_ENTRY
#error "OBS_FUZZ_ENTRY must name the target's entry function"
#endif

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    return OBS_FUZZ_ENTRY(data, size);
}
