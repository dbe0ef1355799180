/* Compiled by `make test` as C99, C11 and C++ with strict warnings: the
   implementation translation unit. */
#define SQFFD_IMPLEMENTATION
#include "../sqffd.h"
