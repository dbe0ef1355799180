/* The implementation translation unit: the core object of every build
   flavour (build/<flavour>/sqffd.o, linked into the unit tests, checked by
   make check-symbols), and the file make check-header compiles as C99, C11
   and C++ with strict warnings. */
#define SQFFD_IMPLEMENTATION
#include "../sqffd.h"
