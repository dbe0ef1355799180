/* A second translation unit that only uses the API (no implementation):
   linked against check_header.c, it catches duplicate or missing symbols;
   linked against an implementation built with another SQFFD_MAX_LATTICE,
   it must fail to link (sqffd_model_validate takes a model). */
#include "../sqffd.h"

#ifdef SQFFD_STATIC /* with SQFFD_STATIC the implementation must be in this unit */
#define SQFFD_IMPLEMENTATION
#include "../sqffd.h"
#endif

int sqffd_check_use(void);
int sqffd_check_use(void)
{
    return sqffd_result_string(SQFFD_ERROR_CANCELLED)[0] != '\0' &&
           sqffd_model_validate(NULL) == SQFFD_ERROR_INVALID_ARGUMENT;
}

int main(void) { return sqffd_check_use() ? 0 : 1; }
