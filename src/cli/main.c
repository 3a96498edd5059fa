/* placeholder until the CLI lands (owned by the lead) */
#include "core/obs.h"
#include <stdio.h>
int main(void) { printf("obscura %s\n", OBS_VERSION_STRING); return 0; }
