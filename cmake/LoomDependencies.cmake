# Every dependency comes from Debian 12's packages (scripts/install-deps.sh).
find_package(PkgConfig REQUIRED)
pkg_check_modules(ARAVIS REQUIRED IMPORTED_TARGET aravis-0.8)
pkg_check_modules(LIBUSB REQUIRED IMPORTED_TARGET libusb-1.0)
pkg_check_modules(LIBMODBUS REQUIRED IMPORTED_TARGET libmodbus)
pkg_check_modules(HDF5 REQUIRED IMPORTED_TARGET hdf5)  # libhdf5-dev: the AxF-style export
set(LOOM_HDF5 PkgConfig::HDF5)

find_package(Eigen3 3.4 REQUIRED NO_MODULE)
find_package(yaml-cpp REQUIRED)
find_package(nlohmann_json 3 REQUIRED)
find_package(CLI11 REQUIRED)
find_package(OpenCV 4 REQUIRED COMPONENTS core imgproc imgcodecs calib3d highgui)
find_package(Ceres 2 REQUIRED)
find_package(OpenEXR 3 CONFIG REQUIRED)
find_package(Torch REQUIRED)
# LibTorch's CMake config links libtorch and libtorch_cpu with --no-as-needed (so that CUDA kernels,
# which register themselves when their library loads, are never dropped), and so every executable
# that links loom_fitting loaded them, even those that never run the CNN. Loading them costs about
# 0.8 s of CPU (their static initialisers register every operator): fitting_test's 66 tests paid it
# once each. Debian's LibTorch has no CUDA: link them only where the CNN's code needs them.
foreach(torch_target torch_cpu torch)
  set_property(TARGET ${torch_target}_library PROPERTY INTERFACE_LINK_LIBRARIES
    "-Wl,--as-needed,\"$<TARGET_FILE:${torch_target}>\",--no-as-needed"
    "$<TARGET_PROPERTY:${torch_target},INTERFACE_LINK_LIBRARIES>")
endforeach()
list(REMOVE_ITEM TORCH_LIBRARIES torch)  # torch_library brings it, as needed, with its usage requirements
find_package(Threads REQUIRED)
find_package(ZLIB REQUIRED)  # PNG text chunks (core/output_file.cc)
find_package(PNG REQUIRED)  # the exporters' 8-bit PNGs (fitting/report)

if(LOOM_BUILD_TESTS)
  pkg_check_modules(UMOCKDEV REQUIRED IMPORTED_TARGET umockdev-1.0)
  find_package(GTest REQUIRED)
  include(GoogleTest)
endif()
if(LOOM_BUILD_BENCH)
  find_package(benchmark REQUIRED)
endif()
