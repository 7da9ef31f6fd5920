#include <gtest/gtest.h>

#include "lensim/util/error.h"
#include "lensim/util/vec.h"

using namespace lensim;

TEST(FileLoc, FormatsCompilerStyle) {
  EXPECT_EQ((FileLoc{"a.dat", 3, 7}.str()), "a.dat:3:7");
  EXPECT_EQ((FileLoc{"a.dat", 3, 0}.str()), "a.dat:3");
  EXPECT_EQ((FileLoc{"a.dat", 0, 0}.str()), "a.dat");
  EXPECT_EQ(FileLoc{}.str(), "");
}

TEST(Error, WhatCarriesLocation) {
  Error e(FileLoc{"lens.dat", 4, 2}, "bad value");
  EXPECT_STREQ(e.what(), "lens.dat:4:2: error: bad value");
  EXPECT_EQ(e.message(), "bad value");
  EXPECT_EQ(e.loc().line, 4);
  Error plain("no file");
  EXPECT_STREQ(plain.what(), "error: no file");
}

TEST(Diagnostic, FormatsSeverity) {
  Diagnostic d{Severity::Warning, FileLoc{"x.pbrt", 1, 1}, "unused"};
  EXPECT_EQ(d.str(), "x.pbrt:1:1: warning: unused");
}

TEST(Vec3, Algebra) {
  Vec3 a{1, 2, 3}, b{4, 5, 6};
  EXPECT_EQ(dot(a, b), 32.0);
  EXPECT_EQ(cross(Vec3{1, 0, 0}, Vec3{0, 1, 0}), (Vec3{0, 0, 1}));
  EXPECT_NEAR(length(normalize(b)), 1.0, 1e-15);
}
