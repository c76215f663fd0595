// Replays fuzz inputs through LLVMFuzzerTestOneInput without libFuzzer, so the corpus runs as a
// regression test under gcc and ctest. Arguments: files or folders of inputs. Also feeds a fixed set
// of generated inputs (empty, every single byte, pseudo-random buffers) so that the test is never empty.
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <random>
#include <vector>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size);

namespace {
std::size_t run_file(const std::filesystem::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::vector<std::uint8_t> bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  LLVMFuzzerTestOneInput(bytes.data(), bytes.size());
  return 1;
}
}  // namespace

int main(int argc, char** argv) {
  std::size_t files = 0;
  for (int i = 1; i < argc; ++i) {
    const std::filesystem::path p{argv[i]};
    if (std::filesystem::is_directory(p)) {
      for (const auto& e : std::filesystem::recursive_directory_iterator(p))
        if (e.is_regular_file()) files += run_file(e.path());
    } else if (std::filesystem::exists(p)) {
      files += run_file(p);
    } else {
      std::fprintf(stderr, "no such corpus: %s\n", argv[i]);
      return 1;
    }
  }
  LLVMFuzzerTestOneInput(nullptr, 0);
  for (int b = 0; b < 256; ++b) {
    const auto byte = static_cast<std::uint8_t>(b);
    LLVMFuzzerTestOneInput(&byte, 1);
  }
  std::mt19937 rng{12345};
  std::vector<std::uint8_t> buf;
  for (int n = 0; n < 20000; ++n) {
    buf.resize(rng() % 2048);
    for (auto& x : buf) x = static_cast<std::uint8_t>(rng());
    LLVMFuzzerTestOneInput(buf.data(), buf.size());
  }
  std::printf("replayed %zu corpus files and 20257 generated inputs\n", files);
  return 0;
}
