#include "test.h"

void suite_ffd(void)
{
}
