// BORESIGHT_CLONES: an x86-64-v3 (AVX2 + FMA) clone of a hot function beside the baseline, chosen once
// at load time (GCC target_clones, an ifunc: no allocation, no lock). GCC on x86-64 Linux only;
// -DBORESIGHT_NO_TARGET_CLONES turns it off. Files that use it are compiled with -ffp-contract=fast:
// the v3 clone fuses multiply-adds, so its results can differ from the baseline's in the last bits
// (rounding), never between runs on one machine.
#pragma once

#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__) && defined(__linux__) && \
    !defined(BORESIGHT_NO_TARGET_CLONES)
#define BORESIGHT_CLONES __attribute__((target_clones("arch=x86-64-v3", "default")))
#else
#define BORESIGHT_CLONES
#endif
