// Linked into every test of the ThreadSanitizer build (STRATA_TSAN), so that plain `ctest`,
// and gtest's test discovery, run with these settings without any environment.
extern "C" {

// Stop at the first report: a race fails the test instead of scrolling past.
const char* __tsan_default_options() { return "halt_on_error=1 second_deadlock_stack=1"; }

// OpenNI2, which PCL's io library links and Strata never calls, unlocks a mutex it never
// locked in its static initialisers. Nothing of Strata's is suppressed.
const char* __tsan_default_suppressions() { return "called_from_lib:libOpenNI2.so.0\n"; }

}  // extern "C"
