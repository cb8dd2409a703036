// The message catalogues of data/i18n/: every language has every English key with the same
// {{variables}}, the rules' English words are the rules file's, and a lookup interpolates, takes
// its plural form and names what is missing.
#include <gtest/gtest.h>

#include <fstream>
#include <regex>
#include <set>
#include <sstream>

#include "forklift/evaluation/event_words.h"
#include "forklift/i18n/catalogue.h"

namespace {

using forklift::i18n::Catalogue;
using nlohmann::json;
const std::string kData = FORKLIFT_DATA_DIR;

TEST(Catalogue, EveryLanguageHasEveryEnglishKeyWithItsVariables) {
  const Catalogue& c = forklift::i18n::shipped();
  const auto english = c.flat("en");
  ASSERT_GT(english.size(), 100u);
  ASSERT_TRUE(c.has_language("es"));
  for (const std::string& lang : c.languages()) {
    if (lang == "en") continue;
    const auto other = c.flat(lang);
    for (const auto& [key, text] : english) {
      const auto it = other.find(key);
      if (it == other.end()) {
        ADD_FAILURE() << lang << " has no \"" << key << "\" (English: \"" << text << "\")";
        continue;
      }
      EXPECT_EQ(forklift::i18n::variables(it->second), forklift::i18n::variables(text))
          << lang << " \"" << key << "\": \"" << it->second << "\" against the English \"" << text << "\"";
      EXPECT_FALSE(it->second.empty()) << lang << " \"" << key << "\" is empty";
    }
    for (const auto& [key, text] : other)
      EXPECT_TRUE(english.count(key)) << lang << " has \"" << key << "\", which English has not: a key left behind";
  }
}

TEST(Catalogue, TheRulesEnglishWordsAreTheRulesFiles) {
  std::ifstream in(kData + "/evaluation/rules.json");
  const json rules = json::parse(in);
  const Catalogue& c = forklift::i18n::shipped();
  for (const json& r : rules.at("rules")) {
    const std::string id = r.at("id");
    EXPECT_EQ(c.text("en", "words:rules." + id + ".title"), r.value("title", "")) << id;
    EXPECT_EQ(c.text("en", "words:rules." + id + ".description"), r.value("description", "")) << id;
  }
}

TEST(Catalogue, TheCertificateAndTheoryEnglishWordsAreTheirFiles) {
  std::ifstream in(kData + "/theory/certification.json");
  const json cert = json::parse(in);
  const Catalogue& c = forklift::i18n::shipped();
  for (const char* key : {"statement", "statement_without_training"})
    EXPECT_EQ(c.text("en", std::string("certificate:") + key), cert.at(key).get<std::string>()) << key;
  for (const auto& [stem, words] : cert.at("truck_classes").items()) {
    if (stem.rfind('_', 0) == 0) continue;  // "_why"
    EXPECT_EQ(c.text("en", "certificate:truck_classes." + stem), words.get<std::string>()) << stem;
    std::ifstream truck(kData + "/trucks/" + stem + ".json");
    EXPECT_EQ(c.text("en", "certificate:trucks." + stem), json::parse(truck).at("name").get<std::string>()) << stem;
  }
  // Every shipped truck's name, as the session pages and the command line word it.
  for (const auto& f : std::filesystem::directory_iterator(kData + "/trucks")) {
    if (f.path().extension() != ".json") continue;
    std::ifstream truck(f.path());
    EXPECT_EQ(c.text("en", "certificate:trucks." + f.path().stem().string()), json::parse(truck).at("name").get<std::string>())
        << f.path().stem();
  }
  // The theory bank's topics and its pass mark's reason, as the theory page words them.
  std::ifstream bank_in(kData + "/theory/questions.json");
  const json bank = json::parse(bank_in);
  for (const auto& [id, topic] : bank.at("topics").items())
    EXPECT_EQ(c.text("en", "web:theory.topic." + id), topic.at("title").get<std::string>()) << id;
  EXPECT_EQ(c.text("en", "web:theory.pass_mark_why"), bank.at("_pass_mark_why").get<std::string>());
  // Every shipped scenario has its title in words, in every language.
  for (const auto& f : std::filesystem::directory_iterator(kData + "/scenarios")) {
    if (f.path().extension() != ".json") continue;
    for (const std::string& lang : c.languages())
      EXPECT_TRUE(c.has(lang, "words:scenarios." + f.path().stem().string())) << lang << " " << f.path().stem();
  }
}

// Every key a page of menu/web names as it is written (data-i18n="key", data-i18n-attr="attr:key",
// t('key') in its script) is in the English catalogue, as it is or with its plural forms: a page
// never shows a key in place of its words. Keys built at run time (t(`mode.${m}`)) are not seen here.
TEST(Catalogue, EveryKeyThePagesNameIsInTheCatalogue) {
  const Catalogue& c = forklift::i18n::shipped();
  const std::regex marked(R"re(data-i18n="([^"]+)")re"), attrs(R"re(data-i18n-attr="([^"]+)")re"),
      called(R"re(\bt\('([a-z_.:0-9]+)')re");
  const auto qualified = [](const std::string& key) { return key.find(':') == std::string::npos ? "web:" + key : key; };
  const auto known = [&](const std::string& key) {
    const std::string k = qualified(key);
    return c.has("en", k) || (c.has("en", k + "_one") && c.has("en", k + "_other"));
  };
  std::set<std::string> seen;
  int files = 0;
  for (const auto& f : std::filesystem::directory_iterator(std::string(FORKLIFT_SOURCE_DIR) + "/menu/web")) {
    const std::string ext = f.path().extension().string();
    if (ext != ".html" && ext != ".js") continue;
    ++files;
    std::ifstream in(f.path());
    std::stringstream text;
    text << in.rdbuf();
    const std::string s = text.str();
    const std::string name = f.path().filename().string();
    for (auto it = std::sregex_iterator(s.begin(), s.end(), marked); it != std::sregex_iterator(); ++it) seen.insert(name + " " + (*it)[1].str());
    for (auto it = std::sregex_iterator(s.begin(), s.end(), called); it != std::sregex_iterator(); ++it) seen.insert(name + " " + (*it)[1].str());
    for (auto it = std::sregex_iterator(s.begin(), s.end(), attrs); it != std::sregex_iterator(); ++it) {
      std::stringstream pairs((*it)[1].str());
      for (std::string pair; std::getline(pairs, pair, ';');) seen.insert(name + " " + pair.substr(pair.find(':') + 1));
    }
  }
  ASSERT_GT(files, 20);
  ASSERT_GT(seen.size(), 300u) << "the pages' keys are read";
  for (const std::string& entry : seen) {
    const std::string key = entry.substr(entry.find(' ') + 1);
    EXPECT_TRUE(known(key)) << entry << ": no such message in English";
  }
}

TEST(Catalogue, LooksUpInterpolatesTakesPluralsAndNamesWhatIsMissing) {
  const auto dir = std::filesystem::path(testing::TempDir()) / "catalogue_lookup";
  std::filesystem::remove_all(dir);  // a run before left its bad file
  std::filesystem::create_directories(dir / "en");
  std::filesystem::create_directories(dir / "es");
  std::ofstream(dir / "en" / "t.json") << R"({"a": {"pupils_one": "{{count}} pupil", "pupils_other": "{{count}} pupils",
    "hello": "Hello {{name}}, mark {{mark}}"}})";
  std::ofstream(dir / "es" / "t.json") << R"({"a": {"pupils_one": "{{count}} alumno", "pupils_other": "{{count}} alumnos"}})";
  const Catalogue c = Catalogue::load(dir);
  EXPECT_EQ(c.text("en", "t:a.pupils", {{"count", 1}}), "1 pupil");
  EXPECT_EQ(c.text("es", "t:a.pupils", {{"count", 602}}), "602 alumnos");
  EXPECT_EQ(c.text("es", "t:a.pupils", {{"count", 0}}), "0 alumnos");
  EXPECT_EQ(c.text("en", "t:a.hello", {{"name", "Ann"}, {"mark", 92}}), "Hello Ann, mark 92");
  EXPECT_TRUE(c.has("es", "t:a.pupils"));
  try {
    c.text("es", "t:a.hello", {{"name", "Ana"}, {"mark", 92}});
    ADD_FAILURE() << "a key missing in Spanish was found";
  } catch (const forklift::i18n::Missing& e) {
    EXPECT_NE(std::string(e.what()).find("\"t:a.hello\""), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("\"es\""), std::string::npos) << e.what();
  }
  EXPECT_THROW(c.text("fr", "t:a.hello", {{"name", "A"}, {"mark", 1}}), forklift::i18n::Missing);
  EXPECT_THROW(c.text("en", "t:a.hello", {{"name", "A"}}), forklift::i18n::Missing);  // {{mark}} not given
  EXPECT_EQ(c.supported("fr"), "en");
  EXPECT_THROW(Catalogue::load(dir / "nowhere"), std::runtime_error);
  std::ofstream(dir / "es" / "bad.json") << R"({"a": 3})";
  EXPECT_THROW(Catalogue::load(dir), std::runtime_error);
}

TEST(Catalogue, AnEventInSpanishReadsSpanishWithADecimalComma) {
  const std::string details = R"({"measured": {"speed_m_s": 3.2}, "thresholds": {"over_limit_m_s": 0.1}})";
  const json es = forklift::event_words(forklift::i18n::shipped(), "es", "speed_open_aisle", details);
  EXPECT_EQ(es["title"], "Exceso de velocidad en un pasillo");
  EXPECT_EQ(es["summary"], "Medido: velocidad 3,20 m/s (11,5 km/h). Límite: margen permitido sobre el límite 0,10 m/s (0,4 km/h).");
  const json en = forklift::event_words(forklift::i18n::shipped(), "en", "speed_open_aisle", details);
  EXPECT_EQ(en["title"], "Too fast in an aisle");
  EXPECT_EQ(en["summary"], "Measured: speed 3.20 m/s (11.5 km/h). Limit: allowed over the limit 0.10 m/s (0.4 km/h).");
  EXPECT_EQ(forklift::worry_words(forklift::i18n::shipped(), "es", 5), "grave");
  EXPECT_EQ(forklift::worry_words(forklift::i18n::shipped(), "es", 7), "nivel 7");
}

}  // namespace
