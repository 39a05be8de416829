/* Host implementation of the test file access: plain stdio. */
#include <stdio.h>

#include "test_support.h"

static FILE *current;

int test_file_open(const char *path)
{
    current = fopen(path, "rb");
    return current == NULL ? -1 : 0;
}

long test_file_read(void *buf, unsigned long n) { return current == NULL ? -1 : (long)fread(buf, 1, n, current); }

void test_file_close(void)
{
    if (current != NULL) {
        fclose(current);
        current = NULL;
    }
}
