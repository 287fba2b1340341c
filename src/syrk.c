/* syrk.c — the rank-k update behind the dense REPS Hessian: H += Y^T Y on
 * tiles held in vector registers (8 x 16 or 4 x 8 entries, below) (GCC vector extensions,
 * one build per instruction set, chosen when the library loads). The
 * vectors run across entries of H, never across rows, so each entry's sum
 * keeps the order and the rounding of the scalar loop: the same bits on
 * every CPU (a BLAS splits the sums by its kernel and thread count). */
#include <stddef.h>

#include "syrk_priv.h"

/* a fused multiply-add would round once where the scalar loop rounds twice */
#ifdef __clang__
#pragma STDC FP_CONTRACT OFF
#endif

/* Loaded and stored through these (unaligned, aliasing) vector types and
 * with the loops over a tile's rows unrolled, the accumulators stay in
 * registers: through memcpy, GCC stored every sum back to the stack after
 * each row (8.6 against 14.0 G multiply-adds/s on dense200's rows). */
typedef double v8d __attribute__((vector_size(64), aligned(8), may_alias));
typedef double v4d __attribute__((vector_size(32), aligned(8), may_alias));

/* One tile shape per register file: TJ rows of H by two vectors of VT
 * columns, whose 2 TJ accumulators must stay in registers. AVX-512 (32
 * registers of 8 doubles): 8 x 16. AVX2 (16 registers of 4 doubles): 4 x 8;
 * 8 x 16 there would need 32 registers and spills every sum to memory
 * (3.4x slower on dense200). Each entry's sum is in row order either way. */
#define SYRK_TILES(name, VT, TJ)                                                        \
static inline __attribute__((always_inline)) void                                      \
name(const double *Y, int mr, int nfp, double *H, int jlo, int jhi)                    \
{                                                                                       \
	enum { TK = 2 * (int)(sizeof(VT) / sizeof(double)) };                           \
	int j0, k0, a, i;                                                               \
                                                                                        \
	for (j0 = jlo; j0 < jhi; j0 += TJ)                                              \
		for (k0 = j0 / TK * TK; k0 < nfp; k0 += TK) {                           \
			VT acc[TJ][2];                                                  \
                                                                                        \
			_Pragma("GCC unroll 16")                                        \
			for (a = 0; a < TJ; a++) {                                      \
				acc[a][0] = *(const VT *)(H + (size_t)(j0 + a) * nfp + k0); \
				acc[a][1] = *(const VT *)(H + (size_t)(j0 + a) * nfp + k0 + TK / 2); \
			}                                                               \
			for (i = 0; i < mr; i++) {                                      \
				const double *y = Y + (size_t)i * nfp;                  \
				const VT b0 = *(const VT *)(y + k0), b1 = *(const VT *)(y + k0 + TK / 2); \
                                                                                        \
				_Pragma("GCC unroll 16")                                \
				for (a = 0; a < TJ; a++) {                              \
					acc[a][0] += y[j0 + a] * b0;                    \
					acc[a][1] += y[j0 + a] * b1;                    \
				}                                                       \
			}                                                               \
			_Pragma("GCC unroll 16")                                        \
			for (a = 0; a < TJ; a++) {                                      \
				*(VT *)(H + (size_t)(j0 + a) * nfp + k0) = acc[a][0];   \
				*(VT *)(H + (size_t)(j0 + a) * nfp + k0 + TK / 2) = acc[a][1]; \
			}                                                               \
		}                                                                       \
}

/* Inlined into one wrapper per instruction set below, so each copy is
 * compiled for its own vector width. PR_SYRK_TJ is a multiple of both
 * tile heights. */
SYRK_TILES(syrk_tiles8, v8d, 8)
SYRK_TILES(syrk_tiles4, v4d, 4)

typedef void syrk_fn(const double *, int, int, double *, int, int);

static void syrk_default(const double *Y, int mr, int nfp, double *H, int jlo, int jhi)
{
	syrk_tiles4(Y, mr, nfp, H, jlo, jhi);
}

static syrk_fn *syrk_impl = syrk_default;

/* The dispatch is by hand rather than through target_clones, whose resolver
 * some compilers (clang 14) emit only for callers in the same file. */
#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
__attribute__((target("avx2"))) static void
syrk_avx2(const double *Y, int mr, int nfp, double *H, int jlo, int jhi)
{
	syrk_tiles4(Y, mr, nfp, H, jlo, jhi);
}

__attribute__((target("avx512f"))) static void
syrk_avx512(const double *Y, int mr, int nfp, double *H, int jlo, int jhi)
{
	syrk_tiles8(Y, mr, nfp, H, jlo, jhi);
}

/* chosen once when the library loads, before any thread can call it */
__attribute__((constructor)) static void syrk_choose(void)
{
	__builtin_cpu_init();
	if (__builtin_cpu_supports("avx512f"))
		syrk_impl = syrk_avx512;
	else if (__builtin_cpu_supports("avx2"))
		syrk_impl = syrk_avx2;
}
#endif

void pr_syrk_acc_rows(const double *Y, int mr, int nfp, double *H, int jlo, int jhi)
{
	syrk_impl(Y, mr, nfp, H, jlo, jhi);
}

int pr_syrk_split(int nfp, int parts, int t)
{
	double total = 0.0, want, sum = 0.0;
	int j0;

	/* the rows from j0 to j0 + PR_SYRK_TJ hold about the columns from j0 on */
	for (j0 = 0; j0 < nfp; j0 += PR_SYRK_TJ)
		total += nfp - j0;
	want = total * t / parts;
	for (j0 = 0; j0 < nfp && sum < want; j0 += PR_SYRK_TJ)
		sum += nfp - j0;
	return t >= parts ? nfp : j0;
}
