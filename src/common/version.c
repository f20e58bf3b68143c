/* The library's version: the header's macros, compiled in. */
#include <spherecull/sc_version.h>

const char *sc_version_string(void)
{
    return SPHERECULL_VERSION_STRING;
}
