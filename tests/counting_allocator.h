// SPDX-License-Identifier: MIT
// A counting allocator for the "no allocation per frame" tests: a test binary that links
// counting_allocator.cpp has every global operator new / delete replaced by versions that count
// allocations while g_count_allocations is true.
#pragma once

#include <atomic>

extern std::atomic<bool> g_count_allocations;
extern std::atomic<long> g_allocations;
