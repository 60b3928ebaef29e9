/* strandcastd: entry point (flags -> app desc). */
#include <stdio.h>

int main(void)
{
    puts("strandcastd " STRANDCAST_VERSION);
    return 0;
}
