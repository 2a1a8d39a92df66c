// lobefit-gpu render rigs: the kernel's own function (rig_at); its body, which
// reconstructs each rig and shades it per wrap, and the box's CENTRE and HALF come from
// gpu/src/rigs.rs; the formulas shared with renderers are the shader library's
// (lf_rig_terms, lf_irradiance9_wrapped). Not exported: only lobefit-gpu runs it.

// Rig l(p) from its vectors at X[off + 9k ..] (lf_rig_terms' accessor convention).
fn rig_at(kind: vec3<u32>, nodes: vec3<u32>, off: u32, p: vec3<f32>) -> array<f32, 9> {
    let r = lf_rig_terms(kind, nodes, CENTRE, HALF, p);
    var l: array<f32, 9>;
    for (var j = 0u; j < r.count; j++) {
        let k = off + 9u * r.index[j];
        for (var i = 0u; i < 9u; i++) {
            l[i] += r.weight[j] * X[k + i];
        }
    }
    return l;
}
