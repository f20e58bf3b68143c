/* CSV cells with RFC 4180 quoting: a field holding a comma, a quote or a
 * line break is quoted and its quotes doubled, so scene names and file
 * paths never shift the columns. Numbers need no quoting and are printed
 * by the caller. */
#ifndef SPHERECULL_COMMON_SC_CSV_H
#define SPHERECULL_COMMON_SC_CSV_H

#include <stdio.h>

/* Writes S as one CSV field (no separator). */
void sc_csv_str(FILE *f, const char *s);

#endif
