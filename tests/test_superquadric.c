#include "test.h"

void suite_superquadric(void)
{
}
