// yamlTextHazard: finds the texts yaml-cpp 0.7 loops forever on (and other malformed YAML),
// and leaves well-formed YAML alone.
#include "rollstep/common/yaml_text.hpp"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

namespace rollstep {
namespace {

TEST(YamlTextHazard, FindsADocumentStartingWithAComma) {
  // Every form a brute-force search over document starts found hanging yaml-cpp 0.7.
  for (const std::string text : {",", ",a: 1", " ,", "\t,x", "\n\n,", "# comment\n,", "---\n,",
                                 "--- ,", "&a ,", "!t ,", "!!str ,", "&a !t ,", "!,", "&x:,",
                                 "%YAML 1.2\n---\n,", "a: 1\n---\n,", "a: 1\n...\n---\n  ,b"}) {
    const std::string h = yamlTextHazard(text);
    EXPECT_NE(h.find("starts with ','"), std::string::npos) << "missed: " << text;
  }
  EXPECT_EQ(yamlTextHazard("a: 1\nb: 2\n---\n,").rfind("line 4:", 0), 0u);
}

TEST(YamlTextHazard, FindsACommaAfterATopLevelScalar) {
  // Also hangs yaml-cpp 0.7 (found by fuzz_settings): refused by the libyaml syntax check.
  for (const std::string text : {"'',", "\"\",", ">\n,", "|-\n,", "'?1{1',", "\"]]}\",>"}) {
    const std::string h = yamlTextHazard(text);
    EXPECT_EQ(h.rfind("line ", 0), 0u) << "missed: " << text << " -> " << h;
  }
}

TEST(YamlTextHazard, RefusesOtherMalformedYamlWithLineAndColumn) {
  EXPECT_EQ(yamlTextHazard("a: [1, 2\n"),
            "line 2, column 1: did not find expected ',' or ']' "
            "while parsing a flow sequence");
  for (const std::string text : {"a: 1\n,b: 2\n", "a: ]\n", "{a: 1\n", "a: 'x\n", "\t- a\n"}) {
    EXPECT_FALSE(yamlTextHazard(text).empty()) << text;
  }
}

TEST(YamlTextHazard, LeavesWellFormedYamlAlone) {
  for (const std::string text :
       {"", "\n", "# only a comment\n", "a: 1\n", "a: x,y\n", "a: [1, 2]\n", "{a: 1, b: 2}\n",
        "'a,b': 1\n", "\",\": 1\n", "a: |\n  ,\n", "---\na: 1\n...\n", "a: 1 # ,\n", "key: --- ,\n",
        "- a\n- [b, c]\n", "a: &x 1\nb: *x\n", "a: .inf\nb: .nan\n", "---\na: 1\n---\nb: 2\n"}) {
    EXPECT_EQ(yamlTextHazard(text), "") << text;
  }
  // Every YAML file of the repository (outside build trees and fuzz inputs).
  int files = 0;
  const std::filesystem::path root = std::filesystem::path(ROLLSTEP_TEST_DATA_DIR) / "../..";
  for (auto it = std::filesystem::recursive_directory_iterator(root);
       it != std::filesystem::recursive_directory_iterator(); ++it) {
    const std::string name = it->path().filename().string();
    if (it->is_directory()) {
      if (name.rfind("build", 0) == 0 || name == ".git" || name == "fuzz" || name == "out") {
        it.disable_recursion_pending();
      }
      continue;
    }
    if (!it->is_regular_file() || it->path().extension() != ".yaml") continue;
    std::ifstream in(it->path());
    std::stringstream ss;
    ss << in.rdbuf();
    EXPECT_EQ(yamlTextHazard(ss.str()), "") << it->path();
    ++files;
  }
  EXPECT_GE(files, 1);
}

TEST(YamlTextHazard, FlowNestingDeeperThan64LevelsIsRefusedInLinearTime) {
  // 100,000 '[' took libyaml 30 s (quadratic); refused at once, naming the line.
  const std::string deep = "a: 1\nb: " + std::string(100000, '[') + "\n";
  EXPECT_EQ(yamlTextHazard(deep).rfind("line 2: flow collections nested deeper than 64", 0), 0u)
      << yamlTextHazard(deep);
  // 64 levels are fine (the YAML is then judged by libyaml: unclosed here).
  const std::string ok = "a: " + std::string(64, '[') + std::string(64, ']') + "\n";
  EXPECT_EQ(yamlTextHazard(ok), "");
  // Brackets inside quoted scalars and comments do not count.
  const std::string quoted = "a: '" + std::string(100, '[') + "'\nb: \"" + std::string(100, '{') +
                             "\"  # " + std::string(100, '[') + "\n";
  EXPECT_EQ(yamlTextHazard(quoted), "");
}

}  // namespace
}  // namespace rollstep
