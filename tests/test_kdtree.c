#include "test.h"

void suite_kdtree(void)
{
}
