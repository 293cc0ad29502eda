// The fuzzing engine where clang's libFuzzer is unavailable: a deterministic mutation loop
// (fixed seed) over the seed corpus, calling the same LLVMFuzzerTestOneInput as libFuzzer.
//
//   fuzz_<name> [-runs=N] [-max_total_time=S] [-seed=K] [-max_len=L]
//               [-artifact_prefix=P] PATH...
// A PATH that is a directory gives seeds; a file is replayed once, before any mutation. With
// files only, they are replayed and the program exits (as libFuzzer does). Mutations: bit
// flips, random bytes, insertions, deletions, duplications, splices of two inputs, and
// tokens that loaders get wrong (nan, inf, huge numbers, markup). On a crash (a sanitizer
// report, an abort, a signal) the input is written to <P>crash-mutate.
#include <fcntl.h>
#include <sanitizer/common_interface_defs.h>
#include <signal.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>
#include <string>
#include <vector>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size);

namespace {

std::string g_input;  // the input being run, for the crash handler
std::string g_crash_path = "crash-mutate";

void saveInput() {
  const int fd = ::open(g_crash_path.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  if (fd < 0) return;
  const ssize_t ignored = ::write(fd, g_input.data(), g_input.size());
  (void)ignored;
  ::close(fd);
  const char msg[] = "\nmutate: crashing input written\n";
  const ssize_t ignored2 = ::write(2, msg, sizeof msg - 1);
  (void)ignored2;
}

void onSignal(int sig) {
  saveInput();
  ::signal(sig, SIG_DFL);
  ::raise(sig);
}

std::string readFile(const std::filesystem::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

void run(const std::string& input) {
  g_input = input;
  LLVMFuzzerTestOneInput(reinterpret_cast<const std::uint8_t*>(g_input.data()), g_input.size());
}

const char* const kTokens[] = {"nan",
                               "-nan",
                               "inf",
                               "-inf",
                               ".nan",
                               ".inf",
                               "-.inf",
                               "1e999",
                               "-1e999",
                               "1e308",
                               "-1",
                               "0",
                               "-0",
                               "1e-320",
                               "0x10",
                               "99999999999",
                               "-2147483648",
                               " ",
                               "\n",
                               "\t",
                               "\"",
                               "'",
                               "<",
                               ">",
                               "/>",
                               "</",
                               "<!--",
                               "-->",
                               "<![CDATA[",
                               "]]>",
                               "&amp;",
                               "&#0;",
                               "<link name=\"x\"/>",
                               "</robot>",
                               "<robot name=\"r\">",
                               "---\n",
                               "...\n",
                               ": ",
                               "- ",
                               "[",
                               "]",
                               "{",
                               "}",
                               "&a ",
                               "*a",
                               "? ",
                               "!!str ",
                               "~",
                               "#",
                               "\xff"};

std::string mutate(std::string s, const std::vector<std::string>& corpus, std::mt19937_64& rng,
                   std::size_t max_len) {
  const auto pick = [&](std::size_t n) { return n == 0 ? 0 : static_cast<std::size_t>(rng() % n); };
  const int count = 1 + static_cast<int>(rng() % 4);
  for (int k = 0; k < count; ++k) {
    switch (rng() % 8) {
      case 0:  // flip a bit
        if (!s.empty()) s[pick(s.size())] ^= static_cast<char>(1u << (rng() % 8));
        break;
      case 1:  // random byte
        if (!s.empty()) s[pick(s.size())] = static_cast<char>(rng() & 0xff);
        break;
      case 2:  // insert random bytes
        s.insert(pick(s.size() + 1), std::string(1 + pick(4), static_cast<char>(rng() & 0xff)));
        break;
      case 3: {  // delete a range
        if (s.empty()) break;
        const std::size_t at = pick(s.size());
        s.erase(at, 1 + pick(std::min<std::size_t>(64, s.size() - at)));
        break;
      }
      case 4: {  // duplicate a range
        if (s.empty()) break;
        const std::size_t at = pick(s.size());
        const std::string piece = s.substr(at, 1 + pick(64));
        s.insert(pick(s.size() + 1), piece);
        break;
      }
      case 5: {  // splice with another input
        const std::string& other = corpus[pick(corpus.size())];
        if (other.empty()) break;
        const std::size_t at = pick(other.size());
        s.insert(pick(s.size() + 1), other.substr(at, 1 + pick(256)));
        break;
      }
      case 6: {  // insert a token
        const char* t = kTokens[pick(sizeof kTokens / sizeof kTokens[0])];
        s.insert(pick(s.size() + 1), t, std::max<std::size_t>(1, std::strlen(t)));
        break;
      }
      default: {  // replace a number with a token
        std::size_t at = pick(s.size() + 1);
        while (at < s.size() && !std::isdigit(static_cast<unsigned char>(s[at]))) ++at;
        if (at >= s.size()) break;
        std::size_t end = at;
        while (end < s.size() && (std::isdigit(static_cast<unsigned char>(s[end])) ||
                                  s[end] == '.' || s[end] == 'e' || s[end] == '-'))
          ++end;
        const char* t = kTokens[pick(17)];  // the numeric ones
        s.replace(at, end - at, t);
        break;
      }
    }
  }
  if (s.size() > max_len) s.resize(max_len);
  return s;
}

}  // namespace

int main(int argc, char** argv) {
  long runs = 5000;
  double seconds = 0.0;
  unsigned long long seed = 1;
  std::size_t max_len = 0;
  std::vector<std::string> corpus;
  std::vector<std::filesystem::path> replay;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    const auto value = [&](const char* flag) -> const char* {
      const std::size_t n = std::strlen(flag);
      return a.compare(0, n, flag) == 0 ? a.c_str() + n : nullptr;
    };
    if (const char* v = value("-runs=")) {
      runs = std::atol(v);
    } else if (const char* v2 = value("-max_total_time=")) {
      seconds = std::atof(v2);
    } else if (const char* v3 = value("-seed=")) {
      seed = std::strtoull(v3, nullptr, 10);
    } else if (const char* v4 = value("-max_len=")) {
      max_len = static_cast<std::size_t>(std::atol(v4));
    } else if (const char* v5 = value("-artifact_prefix=")) {
      g_crash_path = std::string(v5) + "crash-mutate";
    } else if (!a.empty() && a[0] == '-') {
      std::fprintf(stderr, "mutate: ignoring option %s\n", a.c_str());
    } else if (std::filesystem::is_directory(a)) {
      std::vector<std::filesystem::path> files;
      for (const auto& e : std::filesystem::directory_iterator(a)) {
        if (e.is_regular_file()) files.push_back(e.path());
      }
      std::sort(files.begin(), files.end());  // deterministic order
      for (const auto& f : files) corpus.push_back(readFile(f));
    } else {
      replay.push_back(a);
    }
  }
  __sanitizer_set_death_callback(saveInput);
  for (const int sig : {SIGABRT, SIGSEGV, SIGBUS, SIGFPE, SIGILL}) ::signal(sig, onSignal);

  for (const auto& f : replay) {
    std::fprintf(stderr, "mutate: replaying %s\n", f.c_str());
    run(readFile(f));
  }
  if (corpus.empty()) {
    std::fprintf(stderr, "mutate: %zu inputs replayed, no corpus to mutate\n", replay.size());
    return 0;
  }
  if (max_len == 0) {
    for (const auto& c : corpus) max_len = std::max(max_len, c.size());
    max_len = std::max<std::size_t>(max_len + max_len / 4, 4096);
  }
  for (const auto& c : corpus) run(c);
  std::mt19937_64 rng(seed);
  const auto start = std::chrono::steady_clock::now();
  long done = 0;
  for (; done < runs; ++done) {
    if (seconds > 0 &&
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count() > seconds) {
      break;
    }
    run(mutate(corpus[static_cast<std::size_t>(rng() % corpus.size())], corpus, rng, max_len));
  }
  std::fprintf(stderr, "mutate: %ld runs (seed %llu) over %zu seeds, no failure\n", done, seed,
               corpus.size());
  return 0;
}
