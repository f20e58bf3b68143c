// Turns assimp's internal assertions into import errors.
//
// Debian builds assimp with its ai_asserts enabled, and their default handler
// aborts the process: a truncated PLY or a damaged 3MF archive would kill the
// tracer instead of failing the load (tests/test_scene_bad.c has the cases).
// libassimp calls Assimp::aiAssertViolation through the PLT, so this
// definition in the executable interposes on it; throwing an std::exception
// lands in the importer's own catch block, which releases the half-built
// scene and reports the message through aiGetErrorString().
//
// The one C++ file of the project: only a C++ exception can unwind assimp's
// frames cleanly.
#include <stdexcept>
#include <string>

namespace Assimp {
void aiAssertViolation(const char *expression, const char *file, int line);

void aiAssertViolation(const char *expression, const char *file, int line)
{
    throw std::runtime_error(std::string("assimp internal check failed: ") +
                             (expression ? expression : "?") + " (" + (file ? file : "?") + ":" +
                             std::to_string(line) + ")");
}
}  // namespace Assimp

// Referenced from load_assimp.c so the linker always pulls this object out of
// the static library.
extern "C" int sc_scene_assimp_assert_hook(void);
extern "C" int sc_scene_assimp_assert_hook(void)
{
    return 1;
}
