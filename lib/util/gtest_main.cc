// main() for every test program: fixed seeds, so every run is the same.
#include <gtest/gtest.h>

#include <cstdlib>

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  testing::GTEST_FLAG(random_seed) = 1;
  std::srand(1);
  return RUN_ALL_TESTS();
}
