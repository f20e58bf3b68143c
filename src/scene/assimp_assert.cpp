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
#include <exception>
#include <new>
#include <stdexcept>
#include <string>

#include <unistd.h>

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

// In the import child (load_assimp_child.c) only: an exception that cannot be
// caught (the COB reader throws from a destructor while unwinding, so the
// runtime calls std::terminate) still carries the reason in what(); hand it
// to the child's reporter instead of letting abort() lose it.
static void (*child_reporter)(const char *message);

[[noreturn]] static void child_terminate()
{
    const char *what = "unknown C++ exception";
    try {
        std::exception_ptr e = std::current_exception();
        if (e)
            std::rethrow_exception(e);
    } catch (const std::exception &ex) {
        if (child_reporter)
            child_reporter(ex.what());
        _exit(70);
    } catch (...) {
    }
    if (child_reporter)
        child_reporter(what);
    _exit(70);
}

// Out of memory under the child's memory cap: assimp's own recovery from a
// std::bad_alloc is not reliable (a failed aiApplyPostProcessing crashes in
// ~Importer), so the first failed operator new ends the import right here.
static void (*child_oom)(void);

static void child_new_handler()
{
    if (child_oom)
        child_oom();
    _exit(71);
}

extern "C" void sc_scene_assimp_child_hooks(void (*on_terminate)(const char *message),
                                            void (*on_out_of_memory)(void));
extern "C" void sc_scene_assimp_child_hooks(void (*on_terminate)(const char *message),
                                            void (*on_out_of_memory)(void))
{
    child_reporter = on_terminate;
    child_oom = on_out_of_memory;
    std::set_terminate(child_terminate);
    std::set_new_handler(child_new_handler);
}
