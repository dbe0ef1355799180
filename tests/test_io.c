#include "test.h"

void suite_io(void)
{
}
