# Copyright 2026 formation_control developers
#
# Licensed under the Apache License, Version 2.0 (the "License");
# you may not use this file except in compliance with the License.
# You may obtain a copy of the License at
#
#     http://www.apache.org/licenses/LICENSE-2.0
#
# Unless required by applicable law or agreed to in writing, software
# distributed under the License is distributed on an "AS IS" BASIS,
# WITHOUT WARRANTIES OR CONDITIONS OF ANY KIND, either express or implied.
# See the License for the specific language governing permissions and
# limitations under the License.

# Build a rosidl interface package against the ros-jazzy-* PyPI wheels:
#   cmake -DCMAKE_PROJECT_INCLUDE=<this file> ...
# The wheels' exported targets <pkg>::<pkg>__rosidl_generator_py name the CPython and numpy
# include directories of the machine that built the wheels, and CMake refuses an imported
# target whose include directory does not exist. At the end of the project's top directory
# (after every find_package), each missing Python or numpy entry of an imported target is
# replaced by this interpreter's headers. Nothing in the venv is changed; entries that exist
# are kept, so on a ROS installation this does nothing.
cmake_minimum_required(VERSION 3.19)

function(_fc_repoint_wheel_includes)
  find_package(Python3 REQUIRED COMPONENTS Interpreter Development NumPy)
  get_property(targets DIRECTORY "${CMAKE_SOURCE_DIR}" PROPERTY IMPORTED_TARGETS)
  foreach(target IN LISTS targets)
    get_target_property(dirs ${target} INTERFACE_INCLUDE_DIRECTORIES)
    if(NOT dirs)
      continue()
    endif()
    set(fixed "")
    set(changed FALSE)
    foreach(dir IN LISTS dirs)
      if(dir MATCHES "^\\$<" OR EXISTS "${dir}")
        list(APPEND fixed "${dir}")
      elseif(dir MATCHES "numpy")
        list(APPEND fixed ${Python3_NumPy_INCLUDE_DIRS})
        set(changed TRUE)
      elseif(dir MATCHES "python3")
        list(APPEND fixed ${Python3_INCLUDE_DIRS})
        set(changed TRUE)
      else()
        list(APPEND fixed "${dir}")
      endif()
    endforeach()
    if(changed)
      list(REMOVE_DUPLICATES fixed)
      set_target_properties(${target} PROPERTIES INTERFACE_INCLUDE_DIRECTORIES "${fixed}")
    endif()
  endforeach()
endfunction()

cmake_language(DEFER DIRECTORY "${CMAKE_SOURCE_DIR}" CALL _fc_repoint_wheel_includes)
