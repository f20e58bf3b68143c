/* A mesh view checked once, as the ray generators, the oracle and the
 * Embree back end take it. Include after cmocka.h. */
#ifndef SC_TEST_CHECKED_H
#define SC_TEST_CHECKED_H

#include "spherecull/sc_rays.h"

static inline sc_checked_mesh sc_test_checked(const sc_mesh_view *m)
{
    sc_checked_mesh cm;
    assert_int_equal(sc_mesh_check(m, &cm), SC_OK);
    return cm;
}

#endif
