// The translation unit that compiles the tests' precompiled headers (tests/test_headers.cmake);
// it has no code of its own.
