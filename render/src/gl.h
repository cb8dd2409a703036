// Private: OpenGL through OSMesa (libOSMesa exports the gl* functions itself; no loader) and
// small RAII owners for the GL objects the renderer makes. Every owner must be destroyed while
// its context is current.
#pragma once

#define GL_GLEXT_PROTOTYPES 1
#include <GL/osmesa.h>
// osmesa.h includes GL/gl.h; glext.h adds the core-profile entry points (VAOs, instancing).
#include <GL/glext.h>

#include <string>
#include <utility>

namespace forklift::gl {

// A GL name with its deleter: buffers, vertex arrays, programs, textures, framebuffers.
template <void (*Delete)(GLuint)>
class Name {
 public:
  Name() = default;
  explicit Name(GLuint id) : id_(id) {}
  ~Name() { reset(); }
  Name(Name&& o) noexcept : id_(std::exchange(o.id_, 0)) {}
  Name& operator=(Name&& o) noexcept {
    if (this != &o) {
      reset();
      id_ = std::exchange(o.id_, 0);
    }
    return *this;
  }
  GLuint get() const { return id_; }
  void reset() {
    if (id_) Delete(id_);
    id_ = 0;
  }

 private:
  GLuint id_ = 0;
};

inline void delete_buffer(GLuint id) { glDeleteBuffers(1, &id); }
inline void delete_vertex_array(GLuint id) { glDeleteVertexArrays(1, &id); }
inline void delete_program(GLuint id) { glDeleteProgram(id); }
inline void delete_texture(GLuint id) { glDeleteTextures(1, &id); }
inline void delete_framebuffer(GLuint id) { glDeleteFramebuffers(1, &id); }

using Buffer = Name<delete_buffer>;
using VertexArray = Name<delete_vertex_array>;
using Program = Name<delete_program>;
using Texture = Name<delete_texture>;
using Framebuffer = Name<delete_framebuffer>;

Buffer make_buffer();
VertexArray make_vertex_array();

// Compiles and links a vertex + fragment shader pair. Throws std::runtime_error with the
// compiler's log: a shader that does not compile is our bug, but the log is what one needs.
Program make_program(const char* vertex_source, const char* fragment_source);

// Throws std::runtime_error naming `what` if glGetError reports anything.
void check_error(const char* what);

}  // namespace forklift::gl
