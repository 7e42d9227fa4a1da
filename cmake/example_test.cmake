# ctest driver: install the built library to a scratch prefix, then configure, build and run one of
# the examples/ projects against it through find_package(pairgrasp).
#   -DEXAMPLE=<folder in examples/> -DPROGRAM=<executable> -DRUN_ARGS=<;-separated arguments>
file(REMOVE_RECURSE ${WORK_DIR})
execute_process(COMMAND ${CMAKE_COMMAND} --install ${PAIRGRASP_BUILD_DIR} --prefix ${WORK_DIR}/prefix
                RESULT_VARIABLE rc)
if(rc)
  message(FATAL_ERROR "install failed: ${rc}")
endif()
execute_process(COMMAND ${CMAKE_COMMAND} -S ${PAIRGRASP_SOURCE_DIR}/examples/${EXAMPLE} -B ${WORK_DIR}/build
                        -G ${GENERATOR} -DCMAKE_BUILD_TYPE=Release -DCMAKE_PREFIX_PATH=${WORK_DIR}/prefix
                RESULT_VARIABLE rc)
if(rc)
  message(FATAL_ERROR "configuring examples/${EXAMPLE} failed: ${rc}")
endif()
execute_process(COMMAND ${CMAKE_COMMAND} --build ${WORK_DIR}/build RESULT_VARIABLE rc)
if(rc)
  message(FATAL_ERROR "building examples/${EXAMPLE} failed: ${rc}")
endif()
execute_process(COMMAND ${WORK_DIR}/build/${PROGRAM} ${RUN_ARGS}
                WORKING_DIRECTORY ${PAIRGRASP_SOURCE_DIR}
                RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
message("${out}${err}")
if(rc)
  message(FATAL_ERROR "${PROGRAM} exited with ${rc}")
endif()
