/* bench/ep2_floor.py's hand-written kernel: Householder QR (R and Q^T b) of a stack of
 * m x p least-squares problems with the stack innermost, so every operation runs across
 * problems in SIMD lanes: what a compiled EP2 engine's solve could cost (issue 13, option c).
 * Reads B, m, p, then m x p x B matrix entries ([col][row][problem]) and m x B right-hand
 * sides from stdin; prints the best of ``reps`` CPU seconds of one stack, then |R_kk| of
 * problem 0 (checked against numpy's QR by the bench). */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

static void qr(int B, int m, int p, double *A, double *b, double *work) {
  double *v0 = work, *beta = work + B, *d = work + 2 * B;
#define AT(j, i) (A + ((size_t)(j) * m + (i)) * B)
  for (int k = 0; k < p; k++) {
    double *ak = AT(k, k);
    for (int q = 0; q < B; q++) d[q] = 0.0;
    for (int i = k; i < m; i++)
      for (int q = 0; q < B; q++) d[q] += AT(k, i)[q] * AT(k, i)[q];
    for (int q = 0; q < B; q++) {
      double s = sqrt(d[q]), alpha = ak[q] > 0 ? -s : s;
      double vn = d[q] - ak[q] * ak[q] + (ak[q] - alpha) * (ak[q] - alpha);
      v0[q] = ak[q] - alpha;
      ak[q] = alpha;
      beta[q] = vn > 0 ? 2.0 / vn : 0.0;
    }
    for (int j = k + 1; j <= p; j++) { /* column j == p is the right-hand side */
      double *col = j < p ? AT(j, 0) : b;
      for (int q = 0; q < B; q++) d[q] = v0[q] * col[(size_t)k * B + q];
      for (int i = k + 1; i < m; i++)
        for (int q = 0; q < B; q++) d[q] += AT(k, i)[q] * col[(size_t)i * B + q];
      for (int q = 0; q < B; q++) {
        d[q] *= beta[q];
        col[(size_t)k * B + q] -= d[q] * v0[q];
      }
      for (int i = k + 1; i < m; i++)
        for (int q = 0; q < B; q++) col[(size_t)i * B + q] -= d[q] * AT(k, i)[q];
    }
  }
#undef AT
}

int main(void) {
  int B, m, p, reps = 50;
  if (scanf("%d %d %d", &B, &m, &p) != 3 || B < 1 || m < p || p < 1) return 2;
  size_t na = (size_t)p * m * B, nb = (size_t)m * B;
  double *A0 = malloc(na * sizeof *A0), *b0 = malloc(nb * sizeof *b0);
  double *A = malloc(na * sizeof *A), *b = malloc(nb * sizeof *b), *work = malloc(3 * B * sizeof *work);
  for (size_t i = 0; i < na; i++) if (scanf("%lf", A0 + i) != 1) return 2;
  for (size_t i = 0; i < nb; i++) if (scanf("%lf", b0 + i) != 1) return 2;
  double best = 1e30;
  for (int r = 0; r < reps; r++) {
    memcpy(A, A0, na * sizeof *A);
    memcpy(b, b0, nb * sizeof *b);
    struct timespec t0, t1;
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t0);
    qr(B, m, p, A, b, work);
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t1);
    double dt = (t1.tv_sec - t0.tv_sec) + 1e-9 * (t1.tv_nsec - t0.tv_nsec);
    if (dt < best) best = dt;
  }
  printf("%.9g\n", best);
  for (int k = 0; k < p; k++) printf("%.17g\n", fabs(A[((size_t)k * m + k) * B]));
  return 0;
}
