/* sc_ray against Embree 3's RTCRay (include/spherecull/sc_rtcray.h): the
 * byte offsets the header states, checked against embree3/rtcore_ray.h, and
 * the conversions field by field. The old claim "sc_ray is laid out like the
 * RTCRay prefix" fails test_offsets at tmax. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>
#include <cmocka.h>

#include <embree3/rtcore_ray.h>

#include "spherecull/sc_prefilter.h"
#include "spherecull/sc_rtcray.h"

static void test_offsets(void **state)
{
    (void)state;
    /* Shared: org, tnear = tmin, dir. */
    assert_int_equal(offsetof(sc_ray, org), offsetof(struct RTCRay, org_x));
    assert_int_equal(offsetof(sc_ray, org) + 4, offsetof(struct RTCRay, org_y));
    assert_int_equal(offsetof(sc_ray, org) + 8, offsetof(struct RTCRay, org_z));
    assert_int_equal(offsetof(sc_ray, tmin), offsetof(struct RTCRay, tnear));
    assert_int_equal(offsetof(sc_ray, dir), offsetof(struct RTCRay, dir_x));
    assert_int_equal(offsetof(sc_ray, dir) + 4, offsetof(struct RTCRay, dir_y));
    assert_int_equal(offsetof(sc_ray, dir) + 8, offsetof(struct RTCRay, dir_z));
    /* Not shared: RTCRay's time sits where sc_ray has tmax, tfar after it. */
    assert_int_equal(offsetof(struct RTCRay, time), 28);
    assert_int_equal(offsetof(sc_ray, tmax), 28);
    assert_int_equal(offsetof(struct RTCRay, tfar), 32);
    assert_int_not_equal(offsetof(sc_ray, tmax), offsetof(struct RTCRay, tfar));
    assert_true(sizeof(struct RTCRay) > sizeof(sc_ray));
    assert_int_equal(offsetof(struct RTCRayHit, ray), 0);
}

static void test_from_rtc(void **state)
{
    (void)state;
    struct RTCRayHit rh;
    memset(&rh, 0, sizeof rh);
    rh.ray.org_x = 1, rh.ray.org_y = 2, rh.ray.org_z = 3, rh.ray.tnear = 4;
    rh.ray.dir_x = 5, rh.ray.dir_y = 6, rh.ray.dir_z = 7, rh.ray.time = 0.5f, rh.ray.tfar = 9;
    sc_ray s = sc_ray_from_rtc(&rh.ray);
    assert_true(s.org[0] == 1 && s.org[1] == 2 && s.org[2] == 3 && s.tmin == 4);
    assert_true(s.dir[0] == 5 && s.dir[1] == 6 && s.dir[2] == 7);
    assert_true(s.tmax == 9);       /* a cast would give 0.5 (time) */
    sc_ray cast;
    memcpy(&cast, &rh.ray, sizeof cast);
    assert_true(cast.tmax != s.tmax);

    /* The prefilter with the converted ray keeps a sphere on the ray at t = 8,
     * which the cast ray (tmax = time = 0.5) would reject. */
    sc_sphere_block8 blk;
    sc_sphere_block8_init(&blk);
    sc_spheref sp = { { 1 + 8 * 5.0f, 2 + 8 * 6.0f, 3 + 8 * 7.0f }, 1.0f };
    sc_sphere_block8_set(&blk, 0, &sp);
    s.tmin = 0;
    cast.tmin = 0;
    assert_int_equal(sc_reject8(&s, &blk) & 1u, 0);
    assert_int_equal(sc_reject8(&cast, &blk) & 1u, 1);
}

static void test_to_rtc(void **state)
{
    (void)state;
    sc_ray s = { { 1, 2, 3 }, 4, { 5, 6, 7 }, 8 };
    struct RTCRay r = sc_ray_to_rtc(&s);
    assert_true(r.org_x == 1 && r.org_y == 2 && r.org_z == 3 && r.tnear == 4);
    assert_true(r.dir_x == 5 && r.dir_y == 6 && r.dir_z == 7 && r.tfar == 8);
    assert_true(r.time == 0 && r.mask == 0xffffffffu && r.id == 0 && r.flags == 0);
    sc_ray back = sc_ray_from_rtc(&r);
    assert_memory_equal(&back, &s, sizeof s);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_offsets),
        cmocka_unit_test(test_from_rtc),
        cmocka_unit_test(test_to_rtc),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
