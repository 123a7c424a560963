#include "fixture.h"

#include <math.h>
#include <stdarg.h>
#include <setjmp.h>
#include <stdlib.h>
#include <string.h>

#include <cmocka.h>

spec spec_of(int rows, int cols, int method)
{
  spec s = {rows, cols, method, 16, 1, 0.0, 0, NULL};
  return s;
}

sk_settings settings_of(const spec *s)
{
  sk_settings st;
  memset(&st, 0, sizeof st);
  st.rows = s->rows;
  st.cols = s->cols;
  st.max_contacts = s->max_contacts;
  st.method = s->method;
  st.remove_crosstalk = 1;
  st.fill_dead = s->fill_dead;
  st.full_scale = FULL_SCALE;
  st.tared = 1;
  st.pitch_m = 0.005;
  st.compliance_m_per_n = 2e-4;
  st.min_force_n = 0.05;
  st.min_confidence = 0.0;
  st.min_shift_m = 0.0;
  st.force_scale = 1.0;
  st.fill_factor = 0.8;
  st.zero_ref_n = 1.0;
  for (int layer = 0; layer < 2; layer++) {
    st.curves[layer].censor_counts = s->censor;
    st.curves[layer].rim_load_n = s->censor > 0 ? 0.05 : 0.0;
    st.curves[layer].spread_taxels = s->censor > 0 ? 1.0 : 0.0;
    st.curves[layer].bump_power = 2.0;
    st.curves[layer].activation_n = s->censor > 0 ? 0.01 : 0.0;
  }
  sk_taxel_model m = {0.005, 0.8, 0.001, 0.002, 2.0, 1.0, 50.0, 0.0, 0.0, 0.0, FULL_SCALE};
  st.model = m;
  if (s->drift) {
    sk_drift d = {5.0, 0.05, 1.0, 10.0};
    st.drift = d;
  }
  return st;
}

/* sk_new's arrays for a flat rest: baseline, threshold, noise, dead, tables. */
typedef struct {
  double *baseline, *threshold, *noise, *tables;
  unsigned char *dead;
} arrays;

static arrays arrays_of(int rows, int cols, const unsigned char *dead)
{
  size_t n2 = 2 * (size_t)rows * (size_t)cols;
  arrays a = {malloc(sizeof(double) * n2), malloc(sizeof(double) * n2),
              malloc(sizeof(double) * n2), malloc(sizeof(double) * 2 * (FULL_SCALE + 1)),
              calloc(n2, 1)};
  assert_non_null(a.baseline);
  assert_non_null(a.threshold);
  assert_non_null(a.noise);
  assert_non_null(a.tables);
  assert_non_null(a.dead);
  for (size_t i = 0; i < n2; i++) {
    a.baseline[i] = REST;
    a.threshold[i] = 20.0;
    a.noise[i] = 4.0;
  }
  if (dead) {
    memcpy(a.dead, dead, n2);
  }
  for (int i = 0; i <= FULL_SCALE; i++) {
    a.tables[i] = a.tables[FULL_SCALE + 1 + i] = NEWTONS_PER_COUNT * i;
  }
  return a;
}

static void free_arrays(arrays *a)
{
  free(a->baseline);
  free(a->threshold);
  free(a->noise);
  free(a->tables);
  free(a->dead);
}

int try_settings(const sk_settings *settings, unsigned long size, char *message,
                 unsigned long message_size)
{
  int rows = settings->rows > 0 && settings->rows <= 4096 ? settings->rows : 1;
  int cols = settings->cols > 0 && settings->cols <= 4096 ? settings->cols : 1;
  arrays a = arrays_of(rows, cols, NULL);
  sk_kernel *k = (sk_kernel *)&a;  /* not NULL: sk_new must set it */
  int status = sk_new(settings, size, a.baseline, a.threshold, a.noise, NULL, a.dead, a.tables,
                      &k, message, message_size);
  if (status == SK_OK) {
    assert_non_null(k);
    sk_free(k);
  } else {
    assert_null(k);
  }
  free_arrays(&a);
  return status;
}

sk_kernel *kernel_of(const spec *s)
{
  sk_settings st = settings_of(s);
  arrays a = arrays_of(s->rows, s->cols, s->dead);
  sk_kernel *k = NULL;
  char message[200];
  int status = sk_new(&st, sizeof st, a.baseline, a.threshold, a.noise, NULL, a.dead, a.tables,
                      &k, message, sizeof message);
  if (status != SK_OK) {
    fail_msg("sk_new refused a %d x %d kernel: %s", s->rows, s->cols, message);
  }
  /* every array is the kernel's own copy */
  free_arrays(&a);
  return k;
}

double *rest_maps(int rows, int cols)
{
  size_t n2 = 2 * (size_t)rows * (size_t)cols;
  double *maps = malloc(sizeof(double) * n2);
  assert_non_null(maps);
  for (size_t i = 0; i < n2; i++) {
    maps[i] = REST;
  }
  return maps;
}

void press(double *maps, int rows, int cols, double row, double col, double dx, double dy,
           double peak, double sigma)
{
  size_t n = (size_t)rows * (size_t)cols;
  for (int layer = 0; layer < 2; layer++) {
    double r0 = row + layer * dy, c0 = col + layer * dx;
    for (int r = 0; r < rows; r++) {
      for (int c = 0; c < cols; c++) {
        double d2 = ((r - r0) * (r - r0) + (c - c0) * (c - c0)) / (sigma * sigma);
        double *v = &maps[layer * n + (size_t)r * cols + c];
        *v += peak * exp(-0.5 * d2);
        *v = *v > FULL_SCALE ? FULL_SCALE : floor(*v);
      }
    }
  }
}

sk_contact *records_for(const spec *s)
{
  int n = s->rows * s->cols, kmax = s->max_contacts < n ? s->max_contacts : n;
  sk_contact *out = malloc(sizeof(sk_contact) * (size_t)(kmax > 0 ? kmax : 1));
  assert_non_null(out);
  return out;
}
