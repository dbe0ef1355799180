/* A second translation unit that only uses the API (no implementation):
   linked against check_header.c, it catches duplicate or missing symbols;
   linked against an implementation built with another SQFFD_MAX_LATTICE,
   it must fail to link (sqffd_model_validate and sqffd_fit_view take a
   model). With CHECK_USE_FUNCTIONS, a comma-separated list of
   (check_use_fn)-cast public functions, it references exactly those:
   tests/check_lattice_guard.sh links each lattice-dependent function alone
   across a mismatch. */
#include "../sqffd.h"

#ifdef SQFFD_STATIC /* with SQFFD_STATIC the implementation must be in this unit */
#define SQFFD_IMPLEMENTATION
#include "../sqffd.h"
#endif

#ifdef CHECK_USE_FUNCTIONS
typedef void (*check_use_fn)(void);

int main(void)
{
    static const check_use_fn functions[] = {CHECK_USE_FUNCTIONS};
    volatile size_t first = 0;
    return functions[first] == 0;
}
#else
int sqffd_check_use(void);
int sqffd_check_use(void)
{
    return sqffd_result_string(SQFFD_ERROR_CANCELLED)[0] != '\0' &&
           sqffd_model_validate(NULL) == SQFFD_ERROR_INVALID_ARGUMENT &&
           sqffd_fit_view(sqffd_points_packed(NULL, 0), NULL, NULL, NULL, NULL, 0) == SQFFD_ERROR_INVALID_ARGUMENT;
}

int main(void) { return sqffd_check_use() ? 0 : 1; }
#endif
