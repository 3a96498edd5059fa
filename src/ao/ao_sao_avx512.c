/* ao_sao_avx512.c: the SAO AO pass of ao_sao_avx2.c compiled a second time (one algorithm source
 * per ISA), with its cos/sin on 8 doubles in one AVX-512F register instead of two 4-wide halves.
 * Everything else stays 8 floats in AVX2 registers. Per lane the operations and their order are
 * those of the AVX2 and scalar kernels, so all three give the same bytes
 * (tests/test_ao_sao.c, sao_simd_and_scalar_paths_are_bit_identical). The double-precision
 * cos/sin are half the kernel's instructions on the AVX2 path; on the 2-core Zen 5 VM this path
 * takes ~25% less CPU time per call (docs/performance.md, "SAO kernel").
 * Built with GCC only (#pragma GCC target; AO_I_SAO_HAVE_AVX512), selected at run time when the
 * CPU has AVX-512F (ao_i_sao_isa_available); OBS_ISA=avx2 or OBS_ISA=scalar turn it off. */
#define AO_I_SAO_AVX512_BUILD 1
#include "ao_sao_avx2.c"
