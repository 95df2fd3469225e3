// Stands in for <Windows.h> where Broadmark's Core/Clock.h includes it: the
// performance counter, read from the monotonic clock (nanoseconds).
#pragma once

#include <ctime>

union LARGE_INTEGER {
  long long QuadPart;
};

inline int QueryPerformanceFrequency(LARGE_INTEGER* frequency) {
  frequency->QuadPart = 1'000'000'000LL;
  return 1;
}

inline int QueryPerformanceCounter(LARGE_INTEGER* counter) {
  timespec now{};
  clock_gettime(CLOCK_MONOTONIC, &now);
  counter->QuadPart = now.tv_sec * 1'000'000'000LL + now.tv_nsec;
  return 1;
}
