// SPDX-License-Identifier: MIT
// Shared by the level-scale tests: a small dictionary with interface operators, baked once
// per build tree and cached on disk so the test processes ctest starts do not each bake.
#pragma once

#include <cstdio>
#include <cstdlib>

#include "modrt/precompute/bake.h"
#include "modrt/precompute/dictionary_cache.h"
#include "modrt/precompute/shaped_operators.h"

namespace modrt::test {

inline DictionarySettings small_test_settings() { return precompute::quick_dictionary_settings(8); }

inline const Dictionary& small_test_dictionary() {
  static const Dictionary dict = [] {
    Result<Dictionary> d = precompute::load_or_bake_dictionary(small_test_settings(), MODRT_TEST_CACHE_DIR);
    if (!d.ok()) {
      std::fprintf(stderr, "test dictionary: %s\n", d.status().to_string().c_str());
      std::abort();
    }
    return std::move(d).value();
  }();
  return dict;
}

// The test dictionary's interface basis Hrlf (shaped blocks' interfaces), cached beside it.
inline const Matrix& small_test_interface_basis() {
  static const Matrix basis = [] {
    Result<Matrix> b = precompute::load_or_bake_interface_basis(small_test_settings(), MODRT_TEST_CACHE_DIR);
    if (!b.ok()) {
      std::fprintf(stderr, "test interface basis: %s\n", b.status().to_string().c_str());
      std::abort();
    }
    return std::move(b).value();
  }();
  return basis;
}

// Shaped operators (MRT §8) baked for the test dictionary, cached beside it on disk so that
// the test processes after the first load them instead of baking.
inline precompute::ShapedOperatorCache& test_shaped_cache() {
  static precompute::ShapedOperatorCache cache(MODRT_TEST_CACHE_DIR);
  return cache;
}

}  // namespace modrt::test
