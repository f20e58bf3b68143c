/* One monotonic clock for every timing in the tools: seconds since an
 * arbitrary start, never stepped by NTP or the wall clock. */
#ifndef SPHERECULL_COMMON_SC_CLOCK_H
#define SPHERECULL_COMMON_SC_CLOCK_H

double sc_now_seconds(void);

#endif
