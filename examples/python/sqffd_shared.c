/* The shared library build/libsqffd.so (`make shared`): sqffd.h's
   implementation in one translation unit, every public sqffd_ function
   exported with default visibility. examples/python/sqffd.py loads it. */
#define SQFFD_IMPLEMENTATION
#include "../../sqffd.h"
