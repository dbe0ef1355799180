#include "test.h"

void suite_linalg(void)
{
}
