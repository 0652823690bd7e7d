// The target that builds the tests' shared precompiled header (test_pch.h); every test program reuses it.
int main() { return 0; }
