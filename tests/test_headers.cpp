// The target meshcontact_test_headers compiles this empty file only to own
// the test executables' precompiled headers (tests/CMakeLists.txt); the
// headers themselves are listed there.
