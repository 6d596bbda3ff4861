// Mitsuba's built-in shapes as triangle meshes, and mesh utilities used by the loader.
#include <fmt/format.h>

#include <cmath>
#include "core/mesh_io.h"

namespace lt {

MeshDesc makeRectangle() {
    MeshDesc m;
    m.name = "rectangle";
    m.positions = {{-1, -1, 0}, {1, -1, 0}, {1, 1, 0}, {-1, 1, 0}};
    m.normals.assign(4, Vec3(0, 0, 1));
    m.uvs = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};
    m.indices = {0, 1, 2, 0, 2, 3};
    return m;
}

MeshDesc makeCube() {
    MeshDesc m;
    m.name = "cube";
    for (int a = 0; a < 3; ++a)
        for (int s : {-1, 1}) {
            Vec3 n(0.f), u(0.f), v(0.f);
            n[a] = float(s);
            // u x v = n, so the corners below are counter-clockwise seen from outside.
            u[s > 0 ? (a + 1) % 3 : (a + 2) % 3] = 1.f;
            v[s > 0 ? (a + 2) % 3 : (a + 1) % 3] = 1.f;
            uint32_t base = uint32_t(m.positions.size());
            const float c[4][2] = {{-1, -1}, {1, -1}, {1, 1}, {-1, 1}};
            for (auto& k : c) {
                m.positions.push_back(n + k[0] * u + k[1] * v);
                m.normals.push_back(n);
                m.uvs.emplace_back(0.5f * (k[0] + 1.f), 0.5f * (k[1] + 1.f));
            }
            for (uint32_t i : {0u, 1u, 2u, 0u, 2u, 3u}) m.indices.push_back(base + i);
        }
    return m;
}

MeshDesc makeDisk(int segments) {
    MeshDesc m;
    m.name = "disk";
    const double twoPi = 2.0 * 3.14159265358979323846;
    // A regular N-gon of circumradius R has area N/2 R^2 sin(2 pi / N): choose R so it is pi.
    double R = std::sqrt(3.14159265358979323846 / (0.5 * segments * std::sin(twoPi / segments)));
    m.positions.push_back(Vec3(0.f));
    m.uvs.push_back(Vec2(0.5f));
    for (int i = 0; i < segments; ++i) {
        double phi = twoPi * i / segments;
        Vec3 p(float(R * std::cos(phi)), float(R * std::sin(phi)), 0.f);
        m.positions.push_back(p);
        m.uvs.emplace_back(0.5f * p.x + 0.5f, 0.5f * p.y + 0.5f);
    }
    m.normals.assign(m.positions.size(), Vec3(0, 0, 1));
    for (int i = 0; i < segments; ++i) {
        m.indices.push_back(0);
        m.indices.push_back(uint32_t(1 + i));
        m.indices.push_back(uint32_t(1 + (i + 1) % segments));
    }
    return m;
}

double meshArea(const MeshDesc& m) {
    double a = 0.0;
    for (size_t i = 0; i + 2 < m.indices.size(); i += 3) {
        glm::dvec3 p0(m.positions[m.indices[i]]), p1(m.positions[m.indices[i + 1]]), p2(m.positions[m.indices[i + 2]]);
        a += 0.5 * glm::length(glm::cross(p1 - p0, p2 - p0));
    }
    return a;
}

void computeVertexNormals(MeshDesc& m) {
    std::vector<glm::dvec3> acc(m.positions.size(), glm::dvec3(0.0));
    for (size_t i = 0; i + 2 < m.indices.size(); i += 3) {
        uint32_t idx[3] = {m.indices[i], m.indices[i + 1], m.indices[i + 2]};
        glm::dvec3 p[3] = {glm::dvec3(m.positions[idx[0]]), glm::dvec3(m.positions[idx[1]]), glm::dvec3(m.positions[idx[2]])};
        glm::dvec3 n = glm::cross(p[1] - p[0], p[2] - p[0]);
        double len = glm::length(n);
        if (!(len > 0.0)) continue;
        n /= len;
        for (int k = 0; k < 3; ++k) {
            glm::dvec3 e1 = p[(k + 1) % 3] - p[k], e2 = p[(k + 2) % 3] - p[k];
            double l1 = glm::length(e1), l2 = glm::length(e2);
            if (!(l1 > 0.0 && l2 > 0.0)) continue;
            double c = std::clamp(glm::dot(e1, e2) / (l1 * l2), -1.0, 1.0);
            acc[idx[k]] += n * std::acos(c);
        }
    }
    m.normals.resize(m.positions.size());
    for (size_t v = 0; v < acc.size(); ++v) {
        double len = glm::length(acc[v]);
        if (!(len > 1e-30)) {
            m.normals.clear();  // some vertex has no defined normal: use face normals everywhere
            return;
        }
        m.normals[v] = Vec3(acc[v] / len);
    }
}

void validateMesh(const MeshDesc& m, const std::string& what) {
    if (m.indices.size() % 3 != 0)
        throw MeshError(fmt::format("{}: the index count {} is not a multiple of 3", what, m.indices.size()));
    for (size_t i = 0; i < m.indices.size(); ++i)
        if (m.indices[i] >= m.positions.size())
            throw MeshError(fmt::format("{}: triangle {} refers to vertex {} but there are {} vertices", what, i / 3,
                                        m.indices[i], m.positions.size()));
    if (!m.normals.empty() && m.normals.size() != m.positions.size())
        throw MeshError(fmt::format("{}: {} normals for {} vertices", what, m.normals.size(), m.positions.size()));
    if (!m.uvs.empty() && m.uvs.size() != m.positions.size())
        throw MeshError(fmt::format("{}: {} texture coordinates for {} vertices", what, m.uvs.size(), m.positions.size()));
    for (size_t i = 0; i < m.positions.size(); ++i)
        if (!isFinite(m.positions[i]))
            throw MeshError(fmt::format("{}: vertex {} has a NaN or infinite coordinate", what, i));
    for (size_t i = 0; i < m.normals.size(); ++i)
        if (!isFinite(m.normals[i]))
            throw MeshError(fmt::format("{}: normal {} has a NaN or infinite coordinate", what, i));
}

}  // namespace lt
