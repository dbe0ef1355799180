/* The header built with SQFFD_MAX_LATTICE 6, private to this file
   (SQFFD_STATIC), for test_model.c: a model saved by the default build
   loads here when its lattice fits, and saves back to the same bytes. */
#define SQFFD_MAX_LATTICE 6
#define SQFFD_STATIC
#define SQFFD_IMPLEMENTATION
#if defined(__GNUC__)
#pragma GCC diagnostic ignored "-Wunused-function"
#endif
#include "../sqffd.h"
#include <stddef.h>

int lattice6_round_trip(const unsigned char *bytes, size_t size, unsigned char *out, size_t capacity);
int lattice6_round_trip(const unsigned char *bytes, size_t size, unsigned char *out, size_t capacity)
{
    sqffd_model model;
    sqffd_result r = sqffd_model_load(&model, bytes, size);
    if (r != SQFFD_OK) return (int)r;
    return (int)sqffd_model_save(&model, out, capacity);
}
