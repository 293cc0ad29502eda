// The settings table: reads, checks and writes a struct's YAML by one table of fields.
#include "rollstep/common/settings_table.hpp"

#include <gtest/gtest.h>

#include <limits>

namespace rollstep::test_settings {

enum class Colour { Red, Green, Blue };
constexpr std::array<EnumName<Colour>, 3> enumNames(Colour) {
  return {{{Colour::Red, "red"}, {Colour::Green, "green"}, {Colour::Blue, "blue"}}};
}

struct Inner {
  double gain = 2.5;
  int count = 3;
};

struct Outer {
  double dt = 0.01;
  int steps = 10;
  bool enabled = true;
  Colour colour = Colour::Green;
  Eigen::Vector3d offset{0.1, 0.0, -0.2};
  std::vector<double> weights{1.0, 2.0};
  std::vector<std::string> names{"a", "b"};
  Inner inner;
};

settings::Table<Inner> innerTable() {
  return settings::Table<Inner>()
      .field("gain", &Inner::gain, "N/m", settings::Range::closed(0, 10))
      .field("count", &Inner::count, "", settings::Range::closed(1, 5));
}

const settings::Table<Outer>& outerTable() {
  static const settings::Table<Outer> table =
      settings::Table<Outer>()
          .field("dt", &Outer::dt, "s", settings::Range::leftOpen(0, 1))
          .field("steps", &Outer::steps, "", settings::Range::closed(1, 100))
          .field("enabled", &Outer::enabled)
          .field("colour", &Outer::colour)
          .field("offset", &Outer::offset, "m", settings::Range::closed(-1, 1))
          .field("weights", &Outer::weights, "", settings::Range::closed(0, 1e6))
          .field("names", &Outer::names)
          .section("inner", &Outer::inner, innerTable());
  return table;
}

Outer read(const std::string& text, const Outer& base = Outer{}) {
  return settings::readDocument(text, outerTable(), "test settings t.yaml: ", base);
}

std::string errorOf(const std::string& text) {
  try {
    read(text);
  } catch (const std::runtime_error& e) {
    return e.what();
  }
  return "";
}

bool same(const Outer& a, const Outer& b) {
  return a.dt == b.dt && a.steps == b.steps && a.enabled == b.enabled && a.colour == b.colour &&
         a.offset == b.offset && a.weights == b.weights && a.names == b.names &&
         a.inner.gain == b.inner.gain && a.inner.count == b.inner.count;
}

TEST(SettingsTable, AbsentKeysKeepTheirValuesAndGivenKeysAreRead) {
  EXPECT_TRUE(same(read(""), Outer{}));
  const Outer o = read(
      "dt: 0.5\nsteps: 7\nenabled: false\ncolour: blue\noffset: [1, -1, 0.5]\n"
      "weights: [3]\nnames: [x, y, z]\ninner:\n  gain: 4\n");
  EXPECT_EQ(o.dt, 0.5);
  EXPECT_EQ(o.steps, 7);
  EXPECT_FALSE(o.enabled);
  EXPECT_EQ(o.colour, Colour::Blue);
  EXPECT_EQ(o.offset, Eigen::Vector3d(1, -1, 0.5));
  EXPECT_EQ(o.weights, std::vector<double>{3});
  EXPECT_EQ(o.names, (std::vector<std::string>{"x", "y", "z"}));
  EXPECT_EQ(o.inner.gain, 4.0);
  EXPECT_EQ(o.inner.count, 3);  // not given: the default
  // Over another base (a file extending another): only the keys given change.
  Outer base;
  base.steps = 42;
  EXPECT_EQ(read("dt: 0.2\n", base).steps, 42);
  // An empty section keeps its values.
  EXPECT_TRUE(same(read("inner:\n"), Outer{}));
}

TEST(SettingsTable, ErrorsNameTheFileLineAndFullKeyPath) {
  struct Case {
    const char* text;
    const char* message;
  };
  const Case cases[] = {
      {"dt: 0.1\nspeed: 1\n",
       "line 2: unknown key 'speed' (known: dt, steps, enabled, colour, offset, weights, names, "
       "inner)"},
      {"inner:\n  gian: 1\n", "line 2: unknown key 'inner.gian' (known in inner: gain, count)"},
      {"dt: 0.1\ndt: 0.2\n", "line 2: dt: given twice (first on line 1)"},
      {"inner:\n  gain: 1\n  gain: 2\n", "line 3: inner.gain: given twice (first on line 2)"},
      {"dt: 0\n", "line 1: dt: 0 is outside (0, 1]"},
      {"dt: .nan\n", "line 1: dt: .nan is outside (0, 1]"},
      {"dt: fast\n", "line 1: dt: 'fast' is not a number"},
      {"dt: '0.1'\n", "line 1: dt: '0.1' is not a number (it is quoted or tagged)"},
      {"dt: [1]\n", "line 1: dt: expected a single number, got a list"},
      {"dt:\n", "line 1: dt: no value"},
      {"steps: 2.5\n", "line 1: steps: expected an integer, got '2.5'"},
      {"steps: 101\n", "line 1: steps: 101 is outside [1, 100]"},
      {"enabled: yes\n", "line 1: enabled: expected true or false, got 'yes'"},
      {"colour: pink\n", "line 1: colour: expected red, green or blue, got 'pink'"},
      {"colour: 'red'\n",
       "line 1: colour: expected red, green or blue, got 'red' (it is quoted or tagged)"},
      {"offset: [1, 2]\n", "line 1: offset: expected a list of 3 numbers, got a list of 2"},
      {"offset: [0, 0,\n  2]\n", "line 2: offset: 2 is outside [-1, 1]"},
      {"weights: 1\n", "line 1: weights: expected a list of numbers, got a value"},
      {"names: [a, a]\n", "line 1: names: 'a' given twice"},
      {"inner: 3\n", "line 1: inner: expected a mapping, got a value"},
      {"inner:\n  count: 0\n", "line 2: inner.count: 0 is outside [1, 5]"},
      {"- 1\n", "line 1: expected a mapping of key: value"},
      {"[a]: 1\n", "line 1: <key>: a key is not a plain name"},
  };
  for (const Case& c : cases) {
    const std::string e = errorOf(c.text);
    EXPECT_EQ(e.rfind("test settings t.yaml: ", 0), 0u) << c.text << " -> " << e;
    EXPECT_NE(e.find(c.message), std::string::npos) << c.text << " -> " << e;
  }
  EXPECT_NE(errorOf("dt: [1\n").find("test settings t.yaml: YAML error: line 2"), std::string::npos)
      << errorOf("dt: [1\n");
}

TEST(SettingsTable, WriteThenReadGivesEqualSettings) {
  Outer o;
  o.dt = 0.1 + 0.2;  // not representable in few digits
  o.steps = 99;
  o.enabled = false;
  o.colour = Colour::Red;
  o.offset = Eigen::Vector3d(1.0 / 3.0, -0.0, 1e-300);
  o.weights = {};
  o.names = {"left front", "b, c", "d: 'e'"};
  o.inner.gain = 9.999999999999998;
  o.inner.count = 5;
  const std::string text = outerTable().write(o);
  const Outer back = read(text);
  EXPECT_TRUE(same(back, o)) << text;
  EXPECT_EQ(outerTable().write(back), text);
  EXPECT_TRUE(std::signbit(back.offset[1]));
  // Every key is written, sections nested by two spaces.
  EXPECT_NE(text.find("\ninner:\n  gain: 9.999999999999998\n  count: 5\n"), std::string::npos)
      << text;
}

TEST(SettingsTable, DocumentedDefaultsAreTheDefaultConstructedStruct) {
  const std::string doc = outerTable().documented();
  EXPECT_NE(doc.find("dt: 0.01  # [s] (0, 1]\n"), std::string::npos) << doc;
  EXPECT_NE(doc.find("colour: green\n"), std::string::npos) << doc;
  EXPECT_NE(doc.find("  gain: 2.5  # [N/m] [0, 10]\n"), std::string::npos) << doc;
  // The documented text reads back as the defaults.
  EXPECT_TRUE(same(read(doc), Outer{}));
}

TEST(SettingsTable, CheckFindsTheFirstValueOutsideItsRange) {
  Outer o;
  EXPECT_FALSE(outerTable().check(o));
  o.inner.count = 9;
  auto p = outerTable().check(o);
  ASSERT_TRUE(p);
  EXPECT_EQ(p->path, "inner.count");
  EXPECT_EQ(p->what, "9 is outside [1, 5]");
  o = Outer{};
  o.offset[2] = std::numeric_limits<double>::infinity();
  p = outerTable().check(o);
  ASSERT_TRUE(p);
  EXPECT_EQ(p->path, "offset");
  EXPECT_EQ(p->what, "entry 2, inf is outside [-1, 1]");
  o = Outer{};
  o.colour = static_cast<Colour>(7);
  p = outerTable().check(o);
  ASSERT_TRUE(p);
  EXPECT_EQ(p->what, "not red, green or blue");
}

TEST(EnumNames, NamesAndValuesBothWays) {
  EXPECT_STREQ(enumName(Colour::Blue), "blue");
  EXPECT_STREQ(enumName(static_cast<Colour>(9)), "unknown");
  EXPECT_EQ(enumFromName<Colour>("green"), Colour::Green);
  EXPECT_FALSE(enumFromName<Colour>("Green"));
  EXPECT_EQ(enumChoices<Colour>(), "red, green or blue");
}

TEST(SettingsTable, ATableRefusesAKeyTwice) {
  EXPECT_THROW(settings::Table<Inner>().field("gain", &Inner::gain).field("gain", &Inner::gain),
               std::logic_error);
}

// The kinds a description file needs: a name, vectors of any size, lists of name lists,
// lists of sections, required keys.
struct Item {
  std::string label = "item";
  double mass = 1.0;
};

struct Description {
  std::string urdf = "robot.urdf";
  Eigen::VectorXd posture = Eigen::VectorXd::Zero(2);
  std::vector<std::vector<std::string>> pairs;
  std::vector<Item> items;
  std::vector<std::string> words;  // repeats allowed
};

settings::Table<Item> itemTable() {
  return settings::Table<Item>()
      .field("label", &Item::label)
      .required()
      .field("mass", &Item::mass, "kg", settings::Range::leftOpen(0, 100));
}

const settings::Table<Description>& descriptionTable(bool append = false) {
  static const auto make = [](bool append_items) {
    settings::ListOptions<Item> options;
    options.append = append_items;
    options.finish = [](const yaml::Node& item, Item& it, settings::Reader& r,
                        const std::string& path) {
      if (it.label == "heavy" && it.mass < 10) r.fail(item, path + ": a heavy item under 10 kg");
    };
    return settings::Table<Description>()
        .field("urdf", &Description::urdf)
        .required()
        .field("posture", &Description::posture, "rad", settings::Range::closed(-4, 4), 1)
        .field("pairs", &Description::pairs, 0, 2)
        .sections("items", &Description::items, itemTable(), options)
        .field("words", &Description::words, settings::Repeats::Allowed);
  };
  static const settings::Table<Description> replacing = make(false), appending = make(true);
  return append ? appending : replacing;
}

Description readDescription(const std::string& text, const Description& base = Description{},
                            bool append = false) {
  return settings::readDocument(text, descriptionTable(append), "description d.yaml: ", base);
}

std::string descriptionError(const std::string& text) {
  try {
    readDescription(text);
  } catch (const std::runtime_error& e) {
    return e.what();
  }
  return "";
}

bool same(const Description& a, const Description& b) {
  if (a.urdf != b.urdf || a.posture.size() != b.posture.size() || a.posture != b.posture ||
      a.pairs != b.pairs || a.items.size() != b.items.size() || a.words != b.words) {
    return false;
  }
  for (std::size_t i = 0; i < a.items.size(); ++i) {
    if (a.items[i].label != b.items[i].label || a.items[i].mass != b.items[i].mass) return false;
  }
  return true;
}

TEST(SettingsTable, NamesVectorsNameListsAndListsOfSectionsAreRead) {
  const Description d = readDescription(
      "urdf: 'my robot.urdf'\nposture: [0.5, -1, 2]\npairs: [[a, b], [c, d]]\n"
      "items:\n  - label: wheel\n    mass: 2\n  - label: tyre\n");
  EXPECT_EQ(d.urdf, "my robot.urdf");
  ASSERT_EQ(d.posture.size(), 3);
  EXPECT_EQ(d.posture, Eigen::Vector3d(0.5, -1, 2));
  EXPECT_EQ(d.pairs, (std::vector<std::vector<std::string>>{{"a", "b"}, {"c", "d"}}));
  ASSERT_EQ(d.items.size(), 2u);
  EXPECT_EQ(d.items[0].label, "wheel");
  EXPECT_EQ(d.items[0].mass, 2.0);
  EXPECT_EQ(d.items[1].label, "tyre");
  EXPECT_EQ(d.items[1].mass, 1.0);  // each item starts from the defaults
  EXPECT_EQ(readDescription("urdf: r\nwords: [--vx, '0.1', --vy, '0.1']\n").words,
            (std::vector<std::string>{"--vx", "0.1", "--vy", "0.1"}));
  // A list replaces the base's, or (append) adds to it.
  Description base;
  base.items = {Item{"old", 3.0}};
  EXPECT_EQ(readDescription("urdf: r\nitems: [{label: new}]\n", base).items.size(), 1u);
  const Description appended = readDescription("urdf: r\nitems: [{label: new}]\n", base, true);
  ASSERT_EQ(appended.items.size(), 2u);
  EXPECT_EQ(appended.items[0].label, "old");
  EXPECT_EQ(appended.items[1].label, "new");
}

TEST(SettingsTable, ErrorsOfTheDescriptionKindsNameTheLineAndFullKeyPath) {
  struct Case {
    const char* text;
    const char* message;
  };
  const Case cases[] = {
      {"posture: [1]\n", "line 1: missing key 'urdf'"},
      {"", "line 1: missing key 'urdf'"},
      {"urdf: [a]\n", "line 1: urdf: expected a name, got a list"},
      {"urdf: r\nposture: []\n", "line 2: posture: expected at least 1 numbers, got 0"},
      {"urdf: r\nposture: [0, 5]\n", "line 2: posture: 5 is outside [-4, 4]"},
      {"urdf: r\npairs: [a, b]\n", "line 2: pairs[0]: expected a list of names, got a value"},
      {"urdf: r\npairs: [[a, b], [c]]\n", "line 2: pairs[1]: expected 2 names, got 1"},
      {"urdf: r\npairs: [[a, a]]\n", "line 2: pairs[0]: 'a' given twice"},
      {"urdf: r\nitems: {label: x}\n", "line 2: items: expected a list, got a mapping"},
      {"urdf: r\nitems:\n  - 3\n", "line 3: items[0]: expected a mapping, got a value"},
      {"urdf: r\nitems:\n  - label: a\n  - mass: 2\n", "line 4: missing key 'items[1].label'"},
      {"urdf: r\nitems:\n  - label: a\n    mas: 2\n",
       "line 4: unknown key 'items[0].mas' (known in items[0]: label, mass)"},
      {"urdf: r\nitems:\n  - label: a\n    mass: 0\n",
       "line 4: items[0].mass: 0 is outside (0, 100]"},
      {"urdf: r\nitems:\n  - label: a\n    label: b\n",
       "line 4: items[0].label: given twice (first on line 3)"},
      {"urdf: r\nitems:\n  - label: heavy\n", "line 3: items[0]: a heavy item under 10 kg"},
  };
  for (const Case& c : cases) {
    const std::string e = descriptionError(c.text);
    EXPECT_EQ(e.rfind("description d.yaml: ", 0), 0u) << c.text << " -> " << e;
    EXPECT_NE(e.find(c.message), std::string::npos) << c.text << " -> " << e;
  }
}

TEST(SettingsTable, DescriptionKindsWriteReadBackAndAreDocumented) {
  Description d;
  d.urdf = "a b/c.urdf";
  d.posture = Eigen::VectorXd::LinSpaced(5, -0.1, 0.3);
  d.pairs = {{"x", "y"}, {"left front", "z"}};
  d.items = {Item{"first", 0.1 + 0.2}, Item{"second", 99.0}};
  d.words = {"a", "a"};
  const std::string text = descriptionTable().write(d);
  EXPECT_TRUE(same(readDescription(text), d)) << text;
  EXPECT_NE(text.find("items:\n  - label: first\n    mass: 0.30000000000000004\n  - label: "
                      "second\n"),
            std::string::npos)
      << text;
  d.items.clear();
  EXPECT_NE(descriptionTable().write(d).find("items: []\n"), std::string::npos);
  EXPECT_TRUE(same(readDescription(descriptionTable().write(d)), d));
  // Every key with its default, the items' keys as comments under the list.
  const std::string doc = descriptionTable().documented();
  EXPECT_NE(doc.find("urdf: robot.urdf\n"), std::string::npos) << doc;
  EXPECT_NE(doc.find("posture: [0, 0]  # [rad] [-4, 4]\n"), std::string::npos) << doc;
  EXPECT_NE(doc.find("items: []  # a list of mappings, each:\n  #   label: item\n"
                     "  #   mass: 1  # [kg] (0, 100]\n"),
            std::string::npos)
      << doc;
  EXPECT_TRUE(same(readDescription(doc), Description{}));
  // check() names an item's key in full.
  d.items = {Item{}, Item{"b", -1.0}};
  const auto p = descriptionTable().check(d);
  ASSERT_TRUE(p);
  EXPECT_EQ(p->path, "items[1].mass");
}

}  // namespace rollstep::test_settings
