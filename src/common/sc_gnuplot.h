/* gnuplot as a filter: the script goes to its standard input and the
 * picture comes out of its standard output, so a plot is written like any
 * other output file (through sc_write_atomic) and never half-written. The
 * script must not 'set output'. */
#ifndef SPHERECULL_COMMON_SC_GNUPLOT_H
#define SPHERECULL_COMMON_SC_GNUPLOT_H

#include <stdio.h>

/* 0 when gnuplot ran SCRIPT and exited 0 with its output in OUT; -1
 * otherwise (not installed, script error: its messages are discarded). */
int sc_gnuplot(const char *script, FILE *out);

/* sc_write_atomic callback: ctx is the script. */
int sc_gnuplot_write(void *script, FILE *out);

#endif
