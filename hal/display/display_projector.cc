#include "hal/display/display_projector.h"

#include <cstdlib>

#include <opencv2/core.hpp>
#include <opencv2/highgui.hpp>

namespace loom::hal {
namespace {

struct DisplayOptions {
  int width = 1920;
  int height = 1080;
  int screen_x = 0;
  int screen_y = 0;
};

class DisplayProjector : public Projector {
 public:
  DisplayProjector(std::string name, DisplayOptions options)
      : Projector(std::move(name), "display",
                  "screen at " + std::to_string(options.screen_x) + "," + std::to_string(options.screen_y)),
        options_(options),
        window_("loom projector " + this->name()) {}
  ~DisplayProjector() override { DestroyWindow(); }

 protected:
  Result<DeviceIdentity> DoOpen() override {
    const char* display = std::getenv("DISPLAY");
    if (display == nullptr || *display == '\0') {
      return Error(StatusCode::kUnavailable,
                   "no graphical display ($DISPLAY is not set): the projector "
                   "is a screen of a desktop session");
    }
    try {
      cv::namedWindow(window_, cv::WINDOW_NORMAL | cv::WINDOW_GUI_NORMAL);
      cv::moveWindow(window_, options_.screen_x, options_.screen_y);
      cv::setWindowProperty(window_, cv::WND_PROP_FULLSCREEN, cv::WINDOW_FULLSCREEN);
      open_ = true;
    } catch (const cv::Exception& e) {
      return Error(StatusCode::kUnavailable, std::string("cannot open a window: ") + e.what());
    }
    set_native_size(options_.width, options_.height);
    return DeviceIdentity{"", "HDMI display", "", ""};
  }
  Status DoConfigure(const ProjectorSettings&) override { return Status::Ok(); }
  Status DoStart() override { return Status::Ok(); }
  Status DoStop() override { return Status::Ok(); }
  Status DoClose() override {
    DestroyWindow();
    return Status::Ok();
  }
  Status DoShow(const scan::Pattern& pattern) override {
    const cv::Mat image(pattern.height, pattern.width, CV_8UC1, const_cast<uint8_t*>(pattern.pixels.data()));
    return Present(image);
  }
  Status DoBlank() override { return Present(cv::Mat::zeros(options_.height, options_.width, CV_8UC1)); }

 private:
  Status Present(const cv::Mat& image) {
    try {
      cv::imshow(window_, image);
      // Let the window system draw it; the sequencer then waits the projector's settle_ms (hal/rig.h)
      // for the display to show it.
      cv::waitKey(1);
    } catch (const cv::Exception& e) {
      return Error(StatusCode::kUnavailable, std::string("cannot draw: ") + e.what());
    }
    return Status::Ok();
  }
  void DestroyWindow() {
    if (!open_) return;
    try {
      cv::destroyWindow(window_);
    } catch (const cv::Exception&) {
    }
    open_ = false;
  }

  DisplayOptions options_;
  std::string window_;
  bool open_ = false;
};

}  // namespace

void RegisterDisplayBackend(BackendRegistry& registry) {
  registry.Register<Projector>("display", [](const DeviceConfig& config) -> Result<std::unique_ptr<Projector>> {
    DisplayOptions options;
    config.node.Optional("native_width", &options.width);
    config.node.Optional("native_height", &options.height);
    config.node.Optional("screen_x", &options.screen_x);
    config.node.Optional("screen_y", &options.screen_y);
    return std::unique_ptr<Projector>(std::make_unique<DisplayProjector>(config.name, options));
  });
}

}  // namespace loom::hal
