// The C++17 consumer: the same cube as consumer.c, through the headers as a
// C++ renderer includes them (over-aligned packets in a std::vector, which
// C++17's aligned new makes legal), closest hits of single rays, occlusion
// with 8-ray packets. Exits 1 with one line per failed check.
#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>
#include <vector>

#include <spherecull.h>

namespace {

int failures = 0;

void check(bool ok, const char *what, int line)
{
    if (!ok) {
        std::fprintf(stderr, "consumer (C++): line %d: check failed: %s\n", line, what);
        failures++;
    }
}
#define CHECK(cond) check((cond), #cond, __LINE__)

const std::vector<float> cube_pos = {
    0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0,
    0, 0, 1, 1, 0, 1, 1, 1, 1, 0, 1, 1,
};
const std::vector<uint32_t> cube_idx = {
    0, 1, 2, 0, 2, 3, 4, 6, 5, 4, 7, 6, 0, 5, 1, 0, 4, 5,
    3, 2, 6, 3, 6, 7, 0, 3, 7, 0, 7, 4, 1, 5, 6, 1, 6, 2,
};

} // namespace

int main()
{
    static_assert(alignof(sc_ray_packet8) == 32, "packets keep their alignment in C++");
    static_assert(alignof(sc_hit_packet16) == 64, "hit packets keep their alignment in C++");
    CHECK(std::strcmp(sc_version_string(), SPHERECULL_VERSION_STRING) == 0);

    sc_bvh_config cfg;
    sc_bvh_config_default(&cfg);
    cfg.tri_test = SC_TRI_EXACT;
    sc_bvh *bvh = nullptr;
    const sc_mesh_view mesh = { cube_pos.data(), cube_pos.size() / 3, cube_idx.data(), cube_idx.size() / 3, 0, 0 };
    CHECK(sc_bvh_build(&mesh, &cfg, &bvh) == SC_OK);
    if (!bvh)
        return 1;

    const float inf = std::numeric_limits<float>::infinity();
    // From z = -1 with D = (0, 0, 1/2): reaches the z = 0 face (triangle 0 there, x > y) at t = 2.
    sc_ray r = { { 0.75f, 0.25f, -1.0f }, 0.0f, { 0.0f, 0.0f, 0.5f }, inf };
    sc_hitrec h;
    CHECK(sc_trace_closest(bvh, &r, &h, nullptr) == SC_OK);
    CHECK(h.t == 2.0f && h.prim == 0);

    // Packets of 8 shadow-style segments, two per lane pattern: the ones that
    // end before z = 0 are free, the others blocked.
    std::vector<sc_ray_packet8> packets(3);
    for (size_t p = 0; p < packets.size(); p++) {
        sc_ray_packet8 &pk = packets[p];
        CHECK(reinterpret_cast<uintptr_t>(&pk) % 32 == 0);
        for (int i = 0; i < 8; i++) {
            pk.ox[i] = 0.1f + 0.1f * static_cast<float>(i);
            pk.oy[i] = 0.5f + 0.01f * static_cast<float>(p);
            pk.oz[i] = -1.0f;
            pk.dx[i] = 0.0f, pk.dy[i] = 0.0f, pk.dz[i] = 1.0f;
            pk.tmin[i] = 0.0f;
            pk.tmax[i] = (i % 2) ? 0.5f : 1.5f;  // ends at z = -0.5 or z = 0.5
        }
        int32_t valid[8] = { -1, -1, -1, -1, -1, -1, -1, -1 };
        int32_t occluded[8];
        CHECK(sc_trace_any8(bvh, valid, &pk, occluded, nullptr) == SC_OK);
        for (int i = 0; i < 8; i++)
            CHECK(occluded[i] == ((i % 2) ? 0 : 1));
    }
    sc_bvh_free(bvh);
    if (failures)
        return 1;
    std::printf("consumer (C++17): spherecull %s, all checks passed\n", sc_version_string());
    return 0;
}
