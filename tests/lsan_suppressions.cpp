// Linked into every test and fuzz program. Under LeakSanitizer: assimp 5.2 leaks a few objects
// on some error paths of malformed files (a mesh or a hand's link mesh); those leaks are its own.
extern "C" const char* __lsan_default_suppressions() { return "leak:libassimp.so\n"; }
