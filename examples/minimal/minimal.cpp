// The smallest plsr host: loads a scene file, renders it, writes an EXR.
//   minimal SCENE.toml OUT.exr
#include <plsr.hpp>

#include <iostream>

int main(int argc, char **argv) {
    if (argc != 3) {
        std::cerr << "usage: minimal SCENE.toml OUT.exr\n";
        return 2;
    }
    try {
        const plsr::Scene scene = plsr::Scene::load(argv[1]);
        const plsr::Image image = scene.render();  // the scene's settings, all cores
        image.save_exr(argv[2]);
        std::cout << "plsr " << plsr::version() << ": " << image.width() << "x"
                  << image.height() << " written to " << argv[2] << "\n";
    } catch (const plsr::Error &e) {
        std::cerr << "minimal: " << e.what() << "\n";
        return 1;
    }
    return 0;
}
