/* spherecull — what every public header shares: the export macro and the
 * few spellings that differ between C11 and C++.
 *
 * SC_API marks a function of the library's ABI. The shared library is built
 * with hidden visibility, so only SC_API functions are exported; in the
 * static library the attribute changes nothing.
 *
 * SC_ALIGNAS(n) on a struct's first member gives the struct that alignment
 * (C11 _Alignas, C++11 alignas); SC_STATIC_ASSERT is _Static_assert in C
 * and static_assert in C++. Both are standard in C11 and C++11, so the
 * headers need no compiler extension in either language.
 *
 * Threads: macros only.
 */
#ifndef SPHERECULL_SC_API_H
#define SPHERECULL_SC_API_H

#if defined(_WIN32) || defined(__CYGWIN__)
#  if defined(SPHERECULL_BUILDING_SHARED)
#    define SC_API __declspec(dllexport)
#  elif defined(SPHERECULL_SHARED)
#    define SC_API __declspec(dllimport)
#  else
#    define SC_API
#  endif
#elif defined(__GNUC__) || defined(__clang__)
#  define SC_API __attribute__((visibility("default")))
#else
#  define SC_API
#endif

#ifdef __cplusplus
#  define SC_ALIGNAS(n) alignas(n)
#  define SC_STATIC_ASSERT(cond, msg) static_assert(cond, msg)
#else
#  define SC_ALIGNAS(n) _Alignas(n)
#  define SC_STATIC_ASSERT(cond, msg) _Static_assert(cond, msg)
#endif

#endif
