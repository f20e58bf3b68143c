/* spherecull — the version of these headers, and of the library.
 *
 * The macros are the version of the headers a program was compiled with;
 * sc_version_string() is the version of the library it runs with (the
 * shared library may be newer). CMake reads the version from this file:
 * it is the one place the number is written.
 *
 * Threads: sc_version_string may be called from any thread at any time.
 */
#ifndef SPHERECULL_SC_VERSION_H
#define SPHERECULL_SC_VERSION_H

#include "sc_api.h"

#define SPHERECULL_VERSION_MAJOR 0
#define SPHERECULL_VERSION_MINOR 3
#define SPHERECULL_VERSION_PATCH 0
#define SPHERECULL_VERSION_STRING "0.3.0"

#ifdef __cplusplus
extern "C" {
#endif

/* "MAJOR.MINOR.PATCH" of the library linked in; a static string. */
SC_API const char *sc_version_string(void);

#ifdef __cplusplus
}
#endif
#endif
