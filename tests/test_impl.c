/* The one translation unit of the test binary that holds the implementation;
   every test file includes sqffd.h without it, so linkage is exercised. */
#define SQFFD_IMPLEMENTATION
#include "../sqffd.h"
