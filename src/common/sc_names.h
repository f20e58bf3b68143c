/* Name <-> value tables for options and enums: one array of pairs, looked
 * up both ways, so a name is spelled once and the --help list comes from
 * the same table the parser uses. */
#ifndef SPHERECULL_COMMON_SC_NAMES_H
#define SPHERECULL_COMMON_SC_NAMES_H

#include <stddef.h>
#include <stdio.h>
#include <string.h>

typedef struct sc_name {
    const char *name;
    int value;
} sc_name;

#define SC_NAMES_COUNT(table) (sizeof(table) / sizeof((table)[0]))

/* 0 and *value set when NAME is in the table, -1 otherwise. */
static inline int sc_name_lookup(const sc_name *table, size_t n, const char *name, int *value)
{
    for (size_t i = 0; name && i < n; i++)
        if (strcmp(table[i].name, name) == 0) {
            *value = table[i].value;
            return 0;
        }
    return -1;
}

/* The first name of VALUE, or NULL. */
static inline const char *sc_name_of(const sc_name *table, size_t n, int value)
{
    for (size_t i = 0; i < n; i++)
        if (table[i].value == value)
            return table[i].name;
    return NULL;
}

/* "a|b|c" into buf (for usage lines and error messages). */
static inline const char *sc_names_join(const sc_name *table, size_t n, const char *sep, char *buf,
                                        size_t len)
{
    size_t at = 0;
    if (len)
        buf[0] = 0;
    for (size_t i = 0; i < n && at < len; i++) {
        int w = snprintf(buf + at, len - at, "%s%s", i ? sep : "", table[i].name);
        if (w < 0)
            break;
        at += (size_t)w;
    }
    return buf;
}

/* Dense enums, whose names sit in an array indexed by value: the name of
 * v (or `unknown` outside [0, count)), and the value of a name (0, or -1
 * for NULL or an unknown name). */
static inline const char *sc_enum_name(const char *const *names, int count, int v, const char *unknown)
{
    return v >= 0 && v < count ? names[v] : unknown;
}

static inline int sc_enum_lookup(const char *const *names, int count, const char *name, int *v)
{
    for (int i = 0; name && i < count; i++)
        if (strcmp(names[i], name) == 0) {
            *v = i;
            return 0;
        }
    return -1;
}

#endif
