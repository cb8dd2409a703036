// Linked into every test program (cmake/ForkliftTest.cmake): what every test's servers share
// unless a test says otherwise.
#include <cstdlib>

namespace {

// Passwords hashed at the 'test' cost (forklift-server --password-cost): the interactive cost's
// 0.1-0.2 CPU-s a hash was a sixth of the whole suite's CPU, spent on a login or an account in
// almost every server test. Set before main() so that the servers the tests start inherit it; a
// test of the hashing itself passes --password-cost, which wins.
const bool kPasswordCost = setenv("FORKLIFT_PASSWORD_COST", "test", /*overwrite=*/0) == 0;

// The programs the tests start speak English, whatever the machine's language: forklift-cab and
// forklift-menu take their language from LC_ALL, LC_MESSAGES and LANG when not told, and the tests
// read their English. A test of another language says so (--language, or env(1) for LANG).
const bool kLanguage = setenv("LC_ALL", "C.UTF-8", /*overwrite=*/1) == 0;

}  // namespace
