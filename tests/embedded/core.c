/* The sqffd core alone, as firmware builds it: the one translation unit that
   holds the implementation (make embedded cross-compiles it for Cortex-M7). */
#define SQFFD_IMPLEMENTATION
#include "../../sqffd.h"
