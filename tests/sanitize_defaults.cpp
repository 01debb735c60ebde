// Linked into every test of the sanitised build (STRATA_SANITIZE), so that plain `ctest`, and
// gtest's test discovery, run with these settings without any environment.
extern "C" {

// Stop at the first report, with the whole stack: an error fails the test instead of
// scrolling past. Leaks are checked (a process that leaks fails at exit).
const char* __asan_default_options() { return "halt_on_error=1:detect_leaks=1"; }

const char* __ubsan_default_options() { return "halt_on_error=1:print_stacktrace=1"; }

// libomp keeps per-thread data of OpenMP threads started from a non-main thread (a map
// registry's assessment) until it is unloaded; LeakSanitizer counts it as leaked at exit.
// Nothing of Strata's is suppressed.
const char* __lsan_default_suppressions() { return "leak:libomp.so\n"; }

}  // extern "C"
