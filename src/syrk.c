/* syrk.c — the rank-k update behind the dense REPS Hessian: H += Y^T Y on
 * tiles of 8 x 16 entries held in vector registers (GCC vector extensions,
 * one build per instruction set, chosen when the library loads). The
 * vectors run across entries of H, never across rows, so each entry's sum
 * keeps the order and the rounding of the scalar loop: the same bits on
 * every CPU (a BLAS splits the sums by its kernel and thread count). */
#include <string.h>

#include "syrk_priv.h"

/* a fused multiply-add would round once where the scalar loop rounds twice */
#ifdef __clang__
#pragma STDC FP_CONTRACT OFF
#endif

typedef double v8d __attribute__((vector_size(64)));

#define TJ 8  /* rows of H per tile */
#define TK 16 /* columns of H per tile: two vectors */

/* Inlined into one wrapper per instruction set below, so each copy is
 * compiled for its own vector width. */
static inline __attribute__((always_inline)) void
syrk_tiles(const double *Y, int mr, int nfp, double *H)
{
	int j0, k0, a, i;

	for (j0 = 0; j0 < nfp; j0 += TJ)
		for (k0 = j0 / TK * TK; k0 < nfp; k0 += TK) {
			v8d acc[TJ][2];

			for (a = 0; a < TJ; a++)
				memcpy(acc[a], H + (size_t)(j0 + a) * nfp + k0, sizeof acc[a]);
			for (i = 0; i < mr; i++) {
				const double *y = Y + (size_t)i * nfp;
				v8d b[2];

				memcpy(b, y + k0, sizeof b);
				for (a = 0; a < TJ; a++) {
					acc[a][0] += y[j0 + a] * b[0];
					acc[a][1] += y[j0 + a] * b[1];
				}
			}
			for (a = 0; a < TJ; a++)
				memcpy(H + (size_t)(j0 + a) * nfp + k0, acc[a], sizeof acc[a]);
		}
}

typedef void syrk_fn(const double *, int, int, double *);

static void syrk_default(const double *Y, int mr, int nfp, double *H)
{
	syrk_tiles(Y, mr, nfp, H);
}

static syrk_fn *syrk_impl = syrk_default;

/* The dispatch is by hand rather than through target_clones, whose resolver
 * some compilers (clang 14) emit only for callers in the same file. */
#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
__attribute__((target("avx2"))) static void
syrk_avx2(const double *Y, int mr, int nfp, double *H)
{
	syrk_tiles(Y, mr, nfp, H);
}

__attribute__((target("avx512f"))) static void
syrk_avx512(const double *Y, int mr, int nfp, double *H)
{
	syrk_tiles(Y, mr, nfp, H);
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

void pr_syrk_acc(const double *Y, int mr, int nfp, double *H)
{
	syrk_impl(Y, mr, nfp, H);
}
