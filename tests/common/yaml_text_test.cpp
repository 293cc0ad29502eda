// yamlTextHazard: finds the texts yaml-cpp 0.7 loops forever on, and nothing else.
#include "rollstep/common/yaml_text.hpp"

#include <gtest/gtest.h>

#include <string>

namespace rollstep {
namespace {

TEST(YamlTextHazard, FindsADocumentStartingWithAComma) {
  // Every form the brute-force search over document starts found hanging yaml-cpp 0.7.
  for (const std::string text :
       {",", ",a: 1", " ,", "\t,x", "\n\n,", "# comment\n,", "---\n,", "--- ,", "&a ,", "!t ,",
        "!!str ,", "&a !t ,", "%YAML 1.2\n---\n,", "a: 1\n---\n,", "a: 1\n...\n---\n  ,b"}) {
    const std::string h = yamlTextHazard(text);
    EXPECT_NE(h.find("starts with ','"), std::string::npos) << "missed: " << text;
  }
  EXPECT_EQ(yamlTextHazard("a: 1\nb: 2\n---\n,").rfind("line 4:", 0), 0u);
}

TEST(YamlTextHazard, LeavesOrdinaryYamlAlone) {
  for (const std::string text :
       {"", "\n", "# only a comment\n", "a: 1\n", "a: x,y\n", "a: [1, 2]\n", "{a: 1, b: 2}\n",
        "- ,\n", "a: ,\n", "a:\n  ,x\n", "? ,\n", "'a,b': 1\n", "\",\": 1\n", "a: |\n  ,\n",
        "a: 1\n,b: 2\n", "---\na: 1\n...\n", "a: 1 # ,\n", "key: --- ,\n", "a: 1\n----\n,"}) {
    EXPECT_EQ(yamlTextHazard(text), "") << text;
  }
}

}  // namespace
}  // namespace rollstep
