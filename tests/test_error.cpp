#include <gtest/gtest.h>

#include "core/error.h"

TEST(InputError, MessageNamesFileMeshElement) {
  vismap::InputError e(vismap::InputErrorKind::IndexOutOfRange, "a.ply", "bunny", "face", 12,
                       "vertex index 99 out of range (10 vertices)");
  EXPECT_STREQ(e.what(),
               "a.ply: mesh 'bunny': face 12: vertex index 99 out of range (10 vertices)");
  EXPECT_EQ(e.kind(), vismap::InputErrorKind::IndexOutOfRange);
}
