/*
 * Crosstalk: a passive FSR matrix reads each taxel through its row and column
 * lines, so part of the load on a line shows up on every taxel of that line, the same on each;
 * presses cover only a few taxels of a line, so a line's median is its leak. Each row's and
 * column's leak, the median of its taxels when that is a small share of its load, is taken out
 * of both layers of the tared counts (one sweep of median polish, rows then columns), the
 * share of a taxel's own count given back. A median that is not a small share of the line's
 * load is a load spread along the line (a plate, a palm) and is left alone.
 *
 * The step runs only on scans where a line is lifted, mostly at its gate or over: after a tare
 * the gate is CROSSTALK_SIGMAS times each taxel's noise, so a leak under the touch threshold still
 * comes off; before a tare neither the noise nor the rest reading is known, and the touch
 * threshold gates. Each line's share of its load that was taken off is kept (k->line_share)
 * for sk_condition: a force calibration measures the matrix's leak from it.
 */
#include <math.h>
#include <string.h>

#include "internal.h"

/* Largest median, as a share of the line's load above it, taken for leak. */
#define MAX_CROSSTALK 0.05
/* After a tare, a line is lifted by leak when most of its taxels read this many noise sigmas. */
#define CROSSTALK_SIGMAS 3.0

/*
 * A sorting network of 16 inputs: 60 exchanges in 10 layers (Green's first four layers, the
 * rest from Dobbelaere's list; it sorts all 2^16 inputs of 0s and 1s, hence every input). Free
 * of branches, it sorts a line of up to 16 taxels, padded with +inf, in a fixed time, where a
 * selection's comparisons are each a coin toss for the branch predictor (3 to 4 times dearer).
 */
#define NETWORK_INPUTS 16
static const unsigned char NETWORK[][2] = {
  {0, 13}, {1, 12}, {2, 15}, {3, 14}, {4, 8}, {5, 6}, {7, 11}, {9, 10},
  {0, 5}, {1, 7}, {2, 9}, {3, 4}, {6, 13}, {8, 14}, {10, 15}, {11, 12},
  {0, 1}, {2, 3}, {4, 5}, {6, 8}, {7, 9}, {10, 11}, {12, 13}, {14, 15},
  {0, 2}, {1, 3}, {4, 10}, {5, 11}, {6, 7}, {8, 9}, {12, 14}, {13, 15},
  {1, 2}, {3, 12}, {4, 6}, {5, 7}, {8, 10}, {9, 11}, {13, 14},
  {1, 4}, {2, 6}, {5, 8}, {7, 10}, {9, 13}, {11, 14},
  {2, 4}, {3, 6}, {9, 12}, {11, 13},
  {3, 5}, {6, 8}, {7, 9}, {10, 12},
  {3, 4}, {5, 6}, {7, 8}, {9, 10}, {11, 12},
  {6, 7}, {8, 9}};

/* written so that the compiler makes them minsd / maxsd (no branch) */
static double smaller(double a, double b)
{
  return b < a ? b : a;
}

static double larger(double a, double b)
{
  return a < b ? b : a;
}

/* buf[0..len), len <= NETWORK_INPUTS, sorted; buf holds NETWORK_INPUTS doubles */
static void network_sort(double *buf, int len)
{
  for (int i = len; i < NETWORK_INPUTS; i++) {
    buf[i] = INFINITY;
  }
  for (size_t e = 0; e < sizeof(NETWORK) / sizeof(NETWORK[0]); e++) {
    double a = buf[NETWORK[e][0]], b = buf[NETWORK[e][1]];
    buf[NETWORK[e][0]] = smaller(a, b);
    buf[NETWORK[e][1]] = larger(a, b);
  }
}

void sk_crosstalk_gate(sk_kernel *k)
{
  /* CROSSTALK_SIGMAS noise sigmas after a tare, the touch threshold before (the file's comment) */
  const double *gate = k->tared ? k->noise : k->threshold;
  double scale = k->tared ? CROSSTALK_SIGMAS : 1.0;
  for (int i = 0; i < 2 * k->n; i++) {
    k->crosstalk_gate[i] = scale * gate[i];
  }
}

/* The k-th smallest of buf[0..len) (Wirth's selection; reorders buf, leaves it split at k). */
static double select_kth(double *buf, int len, int k)
{
  int lo = 0, hi = len - 1;
  while (lo < hi) {
    double pivot = buf[k];
    int i = lo, j = hi;
    do {
      while (buf[i] < pivot) {
        i++;
      }
      while (pivot < buf[j]) {
        j--;
      }
      if (i <= j) {
        double t = buf[i];
        buf[i] = buf[j];
        buf[j] = t;
        i++;
        j--;
      }
    } while (i <= j);
    if (j < k) {
      lo = i;
    }
    if (k < i) {
      hi = j;
    }
  }
  return buf[k];
}

/*
 * The median of buf[0..len), numpy's way: the mean of the two middle values if len is even.
 * Reorders buf, which holds NETWORK_INPUTS doubles or more.
 */
static double median_of(double *buf, int len)
{
  int mid = (len - 1) / 2;
  if (len <= NETWORK_INPUTS) {
    network_sort(buf, len);
    return len % 2 ? buf[mid] : 0.5 * (buf[mid] + buf[mid + 1]);
  }
  double lo = select_kth(buf, len, mid);
  if (len % 2) {
    return lo;
  }
  /* the next value up is the smallest of those the selection left above mid */
  double hi = buf[mid + 1];
  for (int i = mid + 2; i < len; i++) {
    hi = buf[i] < hi ? buf[i] : hi;
  }
  return 0.5 * (lo + hi);
}

/*
 * A line's leak (stride apart): its median, unless that is not positive or not a small share
 * of the load above it. The median is found only when the line's counts leave it open: with
 * fewer than half of them above 0 it is not positive; with fewer than half at or below `bound`
 * it is larger than any small share (the bound is past the exact threshold by more than the
 * test's rounding). Half the lines of a lifted map are settled so, those away from the touch.
 */
static double line_crosstalk(const double *a, int len, int stride, double *buf)
{
  double sum = 0.0;
  for (int i = 0; i < len; i++) {
    buf[i] = a[i * stride];
    sum += buf[i];
  }
  double bound = (MAX_CROSSTALK * sum + 1e-9 * (fabs(sum) + 1.0)) / (1.0 + MAX_CROSSTALK * len);
  int positive = 0, low = 0, half = (len + 1) / 2;
  for (int i = 0; i < len; i++) {
    positive += buf[i] > 0.0;
    low += buf[i] <= bound;
  }
  if (positive < half || low < half) {
    return 0.0;
  }
  double median = median_of(buf, len);
  if (median > MAX_CROSSTALK * (sum - len * median)) {
    return 0.0;
  }
  return median > 0.0 ? median : 0.0;
}

/* A line's leak as a share of its load (0 on a line without load), MAX_CROSSTALK at most. */
static double crosstalk_share(double leak, double load)
{
  double share = load > 0 ? leak / load : 0.0;
  return share < MAX_CROSSTALK ? share : MAX_CROSSTALK;
}

/*
 * A taxel leaks onto the others of its lines, not onto itself: the lines' leak took a share of
 * its own count too much, which is given back. The leak arrays are turned into the lines' shares
 * in place.
 */
static void give_back_own_crosstalk(double *c, int rows, int cols, double *row_crosstalk,
                               double *col_crosstalk)
{
  /* a line without leak has no share whatever its load, and a taxel of two such lines is
   * divided by 1: both are skipped */
  for (int r = 0; r < rows; r++) {
    double load = 0.0;
    for (int j = 0; j < cols && row_crosstalk[r] != 0.0; j++) {
      load += c[r * cols + j];
    }
    row_crosstalk[r] = crosstalk_share(row_crosstalk[r], load);
  }
  for (int j = 0; j < cols; j++) {
    double load = 0.0;
    for (int r = 0; r < rows && col_crosstalk[j] != 0.0; r++) {
      load += c[r * cols + j];
    }
    col_crosstalk[j] = crosstalk_share(col_crosstalk[j], load);
  }
  for (int r = 0; r < rows; r++) {
    for (int j = 0; j < cols; j++) {
      double keep = 1.0 - row_crosstalk[r] - col_crosstalk[j];
      if (keep != 1.0) {
        c[r * cols + j] /= keep;
      }
    }
  }
}

/*
 * Whether a line of either layer is mostly at its gate or over: rows and columns counted in one
 * sweep of each layer.
 */
static int lifted(const sk_kernel *k)
{
  int rows = k->rows, cols = k->cols, n = k->n;
  double half = 0.5 * (rows < cols ? rows : cols);
  int *col_over = k->iscratch;
  for (int layer = 0; layer < 2; layer++) {
    const double *c = k->counts + layer * n, *gate = k->crosstalk_gate + layer * n;
    memset(col_over, 0, sizeof(int) * cols);
    for (int r = 0; r < rows; r++) {
      int over = 0;
      for (int j = 0; j < cols; j++) {
        int at = c[r * cols + j] >= gate[r * cols + j];
        over += at;
        col_over[j] += at;
      }
      if (over >= half) {
        return 1;
      }
    }
    for (int j = 0; j < cols; j++) {
      if (col_over[j] >= half) {
        return 1;
      }
    }
  }
  return 0;
}

/*
 * Take each line's leak (its median when a small share of its load) out of both layers; each
 * line's share is left in k->line_share and k->crosstalk_removed says whether the scan had any.
 */
void sk_remove_crosstalk(sk_kernel *k)
{
  int rows = k->rows, cols = k->cols, n = k->n;
  k->crosstalk_removed = lifted(k);
  if (!k->crosstalk_removed) {
    return;
  }
  double *buf = k->scratch; /* median_of's: max(line, NETWORK_INPUTS) doubles */
  /* Rows first, then columns: the leak is a row term plus a column term (layers apart). */
  for (int layer = 0; layer < 2; layer++) {
    double *c = k->counts + layer * n;
    double *row_crosstalk = k->line_share + layer * (rows + cols);
    double *col_crosstalk = row_crosstalk + rows;
    for (int r = 0; r < rows; r++) {
      row_crosstalk[r] = line_crosstalk(c + r * cols, cols, 1, buf);
      /* less 0 is the same number: such lines are left as they are */
      for (int j = 0; j < cols && row_crosstalk[r] != 0.0; j++) {
        c[r * cols + j] -= row_crosstalk[r];
      }
    }
    int any_column = 0;
    for (int j = 0; j < cols; j++) {
      col_crosstalk[j] = line_crosstalk(c + j, rows, cols, buf);
      any_column |= col_crosstalk[j] != 0.0;
    }
    for (int r = 0; r < rows && any_column; r++) {
      for (int j = 0; j < cols; j++) {
        c[r * cols + j] -= col_crosstalk[j];
      }
    }
    give_back_own_crosstalk(c, rows, cols, row_crosstalk, col_crosstalk);
  }
}
