/*
 * What the kernel's tests share: a kernel built from a few numbers (a flat rest, a linear force
 * table) and presses drawn into maps. Every array is allocated to its exact size, so that the
 * AddressSanitizer build reports any read or write past it.
 */
#ifndef SKIN_KERNEL_TEST_FIXTURE_H
#define SKIN_KERNEL_TEST_FIXTURE_H

#include <stddef.h>

#include "skin_kernel/skin_kernel.h"

#define REST 100.0        /* every taxel's baseline, counts */
#define FULL_SCALE 4095
#define NEWTONS_PER_COUNT 0.001

typedef struct {
  int rows, cols, method, max_contacts, fill_dead;
  double censor;          /* both curves' censor counts; 0: no censoring */
  int drift;              /* 1: baselines tracked and creep on */
  const unsigned char *dead;  /* (2, rows, cols); NULL: none */
} spec;

/* A spec of rows x cols with the method, every other field its default. */
spec spec_of(int rows, int cols, int method);
/* The settings a spec stands for (sk_new's first argument). */
sk_settings settings_of(const spec *s);
/* A kernel of the spec; the test fails when sk_new refuses it. */
sk_kernel *kernel_of(const spec *s);
/* sk_new of the settings on a flat rest; returns its status, the message in message. */
int try_settings(const sk_settings *settings, unsigned long size, char *message,
                 unsigned long message_size);

/* (2, rows, cols) maps at rest, to draw presses into; free() them. */
double *rest_maps(int rows, int cols);
/*
 * A press: a Gaussian bump of peak counts above rest and width sigma (taxels) centred at (row,
 * col) on the top layer, and at (row + dy, col + dx) on the bottom one; each count is cut at
 * full scale.
 */
void press(double *maps, int rows, int cols, double row, double col, double dx, double dy,
           double peak, double sigma);

/* Records for every contact a kernel of the spec can report: exactly max(kmax, 1) of them. */
sk_contact *records_for(const spec *s);

#endif
