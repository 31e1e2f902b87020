# The GPU build's dependencies (LOOM_GPU_BUILD, docs/gpu-training.md). A GPU machine's image has a
# CUDA LibTorch (PyTorch's) but not Debian's Ceres or OpenCV; scripts/gpu-round.sh carries their
# Debian packages and unpacks them into a prefix named in CMAKE_PREFIX_PATH. Those packages' CMake
# configs name files under /usr (Ceres' its BLAS, OpenCV's every module, most of which do not
# travel), so Ceres, glog and OpenCV's core and imgproc are found here by their files instead, as
# the targets the libraries link: Ceres::ceres, glog::glog, opencv_core, opencv_imgproc.
find_package(Eigen3 3.4 REQUIRED NO_MODULE)
find_package(yaml-cpp REQUIRED)
find_package(nlohmann_json 3 REQUIRED)
find_package(CLI11 REQUIRED)
find_package(OpenEXR 3 CONFIG REQUIRED)
find_package(Torch REQUIRED)
find_package(Threads REQUIRED)
find_package(ZLIB REQUIRED)
find_package(PNG REQUIRED)
enable_language(C)  # FindHDF5 compiles a C probe
find_package(HDF5 REQUIRED COMPONENTS C)  # CMake's module: no pkg-config needed
set(LOOM_HDF5 HDF5::HDF5)

# loom_gpu_imported_library(TARGET HEADER LIBRARY_FILE [DEPS ...]): a shared library found by one of
# its headers and its versioned file (Debian 12's soname: the unversioned link is in -dev packages
# that do not all travel), or else its plain name. A target that exists already is kept (Debian's
# LibTorch brings glog::glog).
function(loom_gpu_imported_library target header library)
  if(TARGET ${target})
    return()
  endif()
  string(MAKE_C_IDENTIFIER "${target}" id)
  string(REGEX REPLACE "^lib(.*)\\.so.*$" "\\1" plain_name "${library}")
  find_path(LOOM_GPU_${id}_INCLUDE "${header}" PATH_SUFFIXES opencv4 REQUIRED)
  find_library(LOOM_GPU_${id}_LIBRARY NAMES "${library}" "${plain_name}" REQUIRED)
  add_library(${target} SHARED IMPORTED GLOBAL)
  set_target_properties(${target} PROPERTIES IMPORTED_LOCATION "${LOOM_GPU_${id}_LIBRARY}"
    INTERFACE_INCLUDE_DIRECTORIES "${LOOM_GPU_${id}_INCLUDE}" INTERFACE_LINK_LIBRARIES "${ARGN}")
  message(STATUS "GPU build: ${target} from ${LOOM_GPU_${id}_LIBRARY}")
endfunction()

loom_gpu_imported_library(glog::glog glog/logging.h libglog.so.1)
loom_gpu_imported_library(Ceres::ceres ceres/ceres.h libceres.so.3 glog::glog Eigen3::Eigen)
loom_gpu_imported_library(opencv_core opencv2/core.hpp libopencv_core.so.406)
loom_gpu_imported_library(opencv_imgproc opencv2/imgproc.hpp libopencv_imgproc.so.406 opencv_core)
