// SPDX-License-Identifier: MIT
// The embeddable runtime configured with MODRT_BUILD_GLES=OFF (built in the scalar-only clang
// job, scripts/test.sh --scalar-clang): the GLES entries still exist, in the creator table
// (runtime/src/backend_table.cpp) and in the C API, and refuse with an error that says why,
// while the CPU and reference entries work as in every build.
#include <gtest/gtest.h>

#include <memory>
#include <string>
#include <vector>

#include "c_api_test_support.h"
#include "level_fixtures.h"
#include "modrt/backends.h"
#include "modrt/dictionary_io.h"
#include "modrt/level_io.h"
#include "modrt/modrt.h"
#include "test_support.h"

namespace modrt {
namespace {

using test::level_reference;
using test::rel_l2;
using test::small_test_dictionary;
using test::test_level;

TEST(RuntimeWithoutGles, CreatorTableRefusesGlesByName) {
  const test::TestLevel& t = test_level("maze11");
  BackendCreateInfo info;
  info.level = &t.level;
  info.dict = &small_test_dictionary();
  Result<std::unique_ptr<Backend>> gles = create_backend(BackendKind::gles, info);
  ASSERT_FALSE(gles.ok());
  EXPECT_EQ(gles.status().code(), ErrorCode::invalid_argument);
  EXPECT_NE(gles.status().message().find("create_backend(gles): this build has no GLES backend"),
            std::string::npos)
      << gles.status().message();
  EXPECT_NE(gles.status().message().find("MODRT_BUILD_GLES=OFF"), std::string::npos)
      << gles.status().message();

  // The other entries of the same table work and agree with core's reference.
  const test::LevelReference ref = level_reference(t.level, t.ld);
  for (BackendKind kind : {BackendKind::cpu, BackendKind::reference}) {
    SCOPED_TRACE(backend_kind_name(kind));
    Result<std::unique_ptr<Backend>> be = create_backend(kind, info);
    ASSERT_TRUE(be.ok()) << be.status().to_string();
    EXPECT_EQ(be.value()->kind(), kind);
    ASSERT_TRUE(be.value()->update(t.ld).ok());
    std::vector<float> lightmap(be.value()->sizes().lightmap);
    ASSERT_TRUE(be.value()->read_lightmap(lightmap).ok());
    EXPECT_LT(rel_l2(lightmap, ref.lightmap), 1e-5);
  }
}

TEST(RuntimeWithoutGles, CApiRefusesGlesContextByName) {
  const test::TestLevel& t = test_level("maze11");
  const std::vector<std::byte> dict_bytes = serialize_dictionary(small_test_dictionary()).value();
  const std::vector<std::byte> level_bytes = serialize_level(t.level).value();
  modrt_dictionary* d = nullptr;
  modrt_level* l = nullptr;
  ASSERT_EQ(modrt_dictionary_load_memory(dict_bytes.data(), dict_bytes.size(), "small", nullptr, &d),
            MODRT_OK)
      << modrt_last_error();
  ASSERT_EQ(modrt_level_load_memory(level_bytes.data(), level_bytes.size(), "maze11", nullptr, &l), MODRT_OK)
      << modrt_last_error();

  modrt_context_options o;
  modrt_context_options_init(&o);
  o.backend = MODRT_BACKEND_GLES;
  modrt_context* c = reinterpret_cast<modrt_context*>(&o);  // must be cleared, not left as is
  test::expect_error(modrt_context_create(d, l, &o, nullptr, &c), MODRT_ERROR_UNSUPPORTED,
                     {"modrt_context_create", "built without the GLES backend"});
  EXPECT_EQ(c, nullptr);

  // The CPU context of the same library works.
  o.backend = MODRT_BACKEND_CPU;
  ASSERT_EQ(modrt_context_create(d, l, &o, nullptr, &c), MODRT_OK) << modrt_last_error();
  ASSERT_NE(c, nullptr);
  modrt_context_destroy(c);
  modrt_level_destroy(l);
  modrt_dictionary_destroy(d);
}

}  // namespace
}  // namespace modrt
