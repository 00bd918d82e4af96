// Loads SDF worlds with libsdformat, the parser Gazebo itself uses, and prints every error it reports.
// Usage: sdf_check MODEL_DIR WORLD...  (model://NAME is looked up as MODEL_DIR/NAME). Exit 1 on any error.
#include <iostream>
#include <string>
#include <sdf/Root.hh>
#include <sdf/World.hh>
#include <sdf/parser.hh>
int main(int argc, char** argv) {
  if (argc < 3) { std::cerr << "usage: sdf_check MODEL_DIR WORLD...\n"; return 2; }
  const std::string models = argv[1];
  sdf::setFindCallback([models](const std::string& uri) {
    const std::string prefix = "model://";
    return uri.rfind(prefix, 0) == 0 ? models + "/" + uri.substr(prefix.size()) : std::string();
  });
  int bad = 0;
  for (int i = 2; i < argc; ++i) {
    sdf::Root root;
    sdf::Errors errors = root.Load(argv[i]);
    for (const auto& e : errors) { std::cout << argv[i] << ": " << e.Message() << "\n"; }
    if (!errors.empty() || root.WorldCount() != 1) { ++bad; continue; }
    std::cout << argv[i] << ": ok, " << root.WorldByIndex(0)->ModelCount() << " models\n";
  }
  return bad ? 1 : 0;
}
