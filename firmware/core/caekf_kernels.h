/*
 * Which linear-algebra kernels a build has (caekf_kernels.c; their declarations: caekf_linalg.h). The build's
 * sizes and links decide: a build sized for one mechanism links only the kernels of its sizes, written out for
 * them, and the code that would call another compiles out (it tests these constants with a plain if).
 */
#ifndef CAEKF_KERNELS_H
#define CAEKF_KERNELS_H

#include "caekf/caekf_config.h"

/* The LU of any size. A sized build whose innovation covariance is 2 x 2 and whose Newton matrix is 4 x 4
 * or factored over its pattern (CAEKF_FIXED_LINKS) runs the fixed-size kernels and closed forms only, and
 * leaves it out. */
#if CAEKF_SIZED
#define CAEKF_LA_GENERAL_LU (CAEKF_SIZED_SENSORS != 2 || (CAEKF_SIZED_BODIES != 4 && !CAEKF_FIXED_LINKS))
#else
#define CAEKF_LA_GENERAL_LU 1
#endif /* CAEKF_SIZED */

/* A build that fixes its mechanism's links (CAEKF_FIXED_LINKS) factors the Newton matrix over the pattern
 * they give it (generated): the 4 x 4 kernels are then not needed, and the dense solve serves a matrix
 * whose LU exchanged rows. */
#define CAEKF_LA_LU4 (!CAEKF_FIXED_LINKS)
#define CAEKF_LA_DENSE_SOLVE (CAEKF_LA_GENERAL_LU || CAEKF_FIXED_LINKS)

/* The state's n for which the full PSD test is written out (0: none): a build sized for substeps, up to
 * CAEKF_PSD_WRITTEN_OUT_MAX_N (tests/unit/test_psd_written_out.c sets it to check that instance). */
#ifndef CAEKF_PSD_WRITTEN_OUT_N
#if CAEKF_SIZED && CAEKF_HAS_SUBSTEPS && CAEKF_N <= CAEKF_PSD_WRITTEN_OUT_MAX_N
#define CAEKF_PSD_WRITTEN_OUT_N CAEKF_SIZED_N
#else
#define CAEKF_PSD_WRITTEN_OUT_N 0
#endif /* CAEKF_SIZED && CAEKF_HAS_SUBSTEPS && ... */
#endif /* CAEKF_PSD_WRITTEN_OUT_N */

#endif /* CAEKF_KERNELS_H */
