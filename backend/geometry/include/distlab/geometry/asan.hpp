#pragma once
// DISTLAB_ASAN is defined when this unit is built with AddressSanitizer (GCC defines
// __SANITIZE_ADDRESS__; clang 14 only answers __has_feature). ASan reserves terabytes of address
// space up front, so code that sets RLIMIT_AS must not do so under it.
#if defined(__SANITIZE_ADDRESS__)
#define DISTLAB_ASAN 1
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
#define DISTLAB_ASAN 1
#endif
#endif
