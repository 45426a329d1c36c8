/* The textbook formulas bench_kernels.c times raddiff against (textbook.c). */
#ifndef RADDIFF_BENCH_TEXTBOOK_H
#define RADDIFF_BENCH_TEXTBOOK_H

#include "raddiff.h"

double textbook_solid_angle(raddiff_vec3 x, raddiff_vec3 a, raddiff_vec3 b, raddiff_vec3 c);
double textbook_triangle_form_factor(raddiff_vec3 x, raddiff_vec3 n, raddiff_vec3 a, raddiff_vec3 b,
                                     raddiff_vec3 c);

#endif
