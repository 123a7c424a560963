/* Sums in numpy's order, so that the kernel's force sums equal the reference's to the bit. */
#include "internal.h"

/* numpy's pairwise summation (8 accumulators per block of up to 128, halves above). */
double sk_sum(const double *a, int n)
{
  if (n < 8) {
    double res = 0.0;
    for (int i = 0; i < n; i++) {
      res += a[i];
    }
    return res;
  }
  if (n <= 128) {
    double r[8];
    int i;
    for (int j = 0; j < 8; j++) {
      r[j] = a[j];
    }
    for (i = 8; i < n - (n % 8); i += 8) {
      for (int j = 0; j < 8; j++) {
        r[j] += a[i + j];
      }
    }
    double res = ((r[0] + r[1]) + (r[2] + r[3])) + ((r[4] + r[5]) + (r[6] + r[7]));
    for (; i < n; i++) {
      res += a[i];
    }
    return res;
  }
  int n2 = n / 2;
  n2 -= n2 % 8;
  return sk_sum(a, n2) + sk_sum(a + n2, n - n2);
}
