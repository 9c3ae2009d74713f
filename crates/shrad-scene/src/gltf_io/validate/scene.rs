//! Everything else a file refers to: materials, textures, samplers and images, cameras, the
//! node hierarchy (a set of trees), scenes, skins and animations.

use serde_json::Value;

use super::{array, number, numbers, uint, unit_factor, unit_factors, JsonCheck};

impl JsonCheck<'_> {
    pub(super) fn materials(&mut self) -> Result<(), String> {
        for (i, m) in array(self.root, "materials", "")?.iter().enumerate() {
            let at = format!("materials[{i}]");
            if let Some(pbr) = m.get("pbrMetallicRoughness").filter(|v| !v.is_null()) {
                let here = format!("{at}.pbrMetallicRoughness");
                unit_factors(pbr, "baseColorFactor", &here, 4)?;
                unit_factor(pbr, "metallicFactor", &here)?;
                unit_factor(pbr, "roughnessFactor", &here)?;
                self.texture_info(pbr, "baseColorTexture", &here)?;
                self.texture_info(pbr, "metallicRoughnessTexture", &here)?;
            }
            unit_factors(m, "emissiveFactor", &at, 3)?;
            for key in ["normalTexture", "occlusionTexture", "emissiveTexture"] {
                self.texture_info(m, key, &at)?;
            }
            if let Some(occ) = m.get("occlusionTexture").filter(|v| !v.is_null()) {
                unit_factor(occ, "strength", &format!("{at}.occlusionTexture"))?;
            }
            if let Some(x) = number(m, "alphaCutoff", &at)? {
                if x < 0.0 {
                    return Err(format!("{at}.alphaCutoff: {x} must be >= 0"));
                }
            }
            match m.get("alphaMode") {
                None | Some(Value::Null) => {}
                Some(Value::String(s)) if ["OPAQUE", "MASK", "BLEND"].contains(&s.as_str()) => {}
                Some(v) => return Err(format!("{at}.alphaMode: {v} is not OPAQUE, MASK or BLEND")),
            }
            if let Some(ext) = m
                .get("extensions")
                .and_then(|e| e.get("KHR_materials_emissive_strength"))
            {
                let here = format!("{at}.extensions.KHR_materials_emissive_strength");
                if let Some(x) = number(ext, "emissiveStrength", &here)? {
                    if x < 0.0 {
                        return Err(format!("{here}.emissiveStrength: {x} must be >= 0"));
                    }
                }
            }
        }
        Ok(())
    }

    pub(super) fn textures_and_images(&mut self) -> Result<(), String> {
        for (i, t) in array(self.root, "textures", "")?.iter().enumerate() {
            let at = format!("textures[{i}]");
            self.reference(t, "source", &at, "images")?;
            for ext in ["EXT_texture_webp", "KHR_texture_basisu"] {
                if let Some(x) = t.pointer(&format!("/extensions/{ext}")) {
                    self.reference(x, "source", &format!("{at}.extensions.{ext}"), "images")?;
                }
            }
            self.reference(t, "sampler", &at, "samplers")?;
        }
        for (i, s) in array(self.root, "samplers", "")?.iter().enumerate() {
            let at = format!("samplers[{i}]");
            for (key, ok) in [
                ("magFilter", &[9728u64, 9729][..]),
                ("minFilter", &[9728, 9729, 9984, 9985, 9986, 9987][..]),
                ("wrapS", &[33071, 33648, 10497][..]),
                ("wrapT", &[33071, 33648, 10497][..]),
            ] {
                if let Some(v) = uint(s, key, &at)? {
                    if !ok.contains(&v) {
                        return Err(format!("{at}.{key}: {v} is not a glTF sampler value"));
                    }
                }
            }
        }
        for (i, img) in array(self.root, "images", "")?.iter().enumerate() {
            let at = format!("images[{i}]");
            let view = self.reference(img, "bufferView", &at, "bufferViews")?;
            let uri = img.get("uri").filter(|v| !v.is_null());
            match (uri, view) {
                (Some(_), Some(_)) => {
                    return Err(format!(
                        "{at}: has both uri and bufferView (the specification allows one)"
                    ))
                }
                (None, None) => return Err(format!("{at}: has neither uri nor bufferView")),
                (Some(u), None) if !u.is_string() => {
                    return Err(format!("{at}.uri: {u} is not a string"))
                }
                (None, Some(_)) if !img.get("mimeType").is_some_and(Value::is_string) => {
                    return Err(format!(
                        "{at}.mimeType: missing (required with a bufferView)"
                    ))
                }
                _ => {}
            }
        }
        Ok(())
    }

    pub(super) fn cameras(&mut self) -> Result<(), String> {
        for (i, c) in array(self.root, "cameras", "")?.iter().enumerate() {
            let at = format!("cameras[{i}]");
            let ty = c
                .get("type")
                .and_then(Value::as_str)
                .ok_or_else(|| format!("{at}.type: missing (required)"))?;
            let here = format!("{at}.{ty}");
            let p = match ty {
                "perspective" | "orthographic" => c
                    .get(ty)
                    .filter(|v| v.is_object())
                    .ok_or_else(|| format!("{here}: missing (required by type '{ty}')"))?,
                _ => {
                    return Err(format!(
                        "{at}.type: '{ty}' is neither perspective nor orthographic"
                    ))
                }
            };
            let need = |key: &str| -> Result<f64, String> {
                number(p, key, &here)?.ok_or_else(|| format!("{here}.{key}: missing (required)"))
            };
            let znear = need("znear")?;
            let zfar = number(p, "zfar", &here)?;
            if ty == "perspective" {
                let yfov = need("yfov")?;
                if yfov <= 0.0 {
                    return Err(format!("{here}.yfov: {yfov} must be > 0 radians"));
                }
                if yfov >= std::f64::consts::PI {
                    // The specification says SHOULD be below pi, not must.
                    self.warnings.push(format!(
                        "{here}.yfov: {yfov} radians is not below pi (180 degrees): pictures use 179 degrees"
                    ));
                }
                if znear <= 0.0 {
                    return Err(format!("{here}.znear: {znear} must be > 0"));
                }
                if let Some(a) = number(p, "aspectRatio", &here)? {
                    if a <= 0.0 {
                        return Err(format!("{here}.aspectRatio: {a} must be > 0"));
                    }
                }
            } else {
                for key in ["xmag", "ymag"] {
                    if need(key)? == 0.0 {
                        return Err(format!("{here}.{key}: must not be zero"));
                    }
                }
                if znear < 0.0 {
                    return Err(format!("{here}.znear: {znear} must be >= 0"));
                }
                if zfar.is_none() {
                    return Err(format!("{here}.zfar: missing (required)"));
                }
            }
            if let Some(f) = zfar {
                if f <= znear {
                    return Err(format!(
                        "{here}.zfar: {f} must be greater than znear {znear}"
                    ));
                }
            }
        }
        Ok(())
    }

    pub(super) fn nodes(&mut self) -> Result<(), String> {
        let nodes = array(self.root, "nodes", "")?;
        let mut parent: Vec<Option<usize>> = vec![None; nodes.len()];
        for (i, n) in nodes.iter().enumerate() {
            let at = format!("nodes[{i}]");
            for (k, c) in self
                .references(n, "children", &at, "nodes")?
                .into_iter()
                .enumerate()
            {
                if let Some(p) = parent[c] {
                    return Err(format!(
                        "{at}.children[{k}]: node {c} is already a child of node {p} (the node hierarchy must be a set of trees)"
                    ));
                }
                parent[c] = Some(i);
            }
            self.reference(n, "mesh", &at, "meshes")?;
            self.reference(n, "camera", &at, "cameras")?;
            self.reference(n, "skin", &at, "skins")?;
            let matrix = numbers(n, "matrix", &at, 16)?;
            let t = numbers(n, "translation", &at, 3)?;
            let r = numbers(n, "rotation", &at, 4)?;
            let s = numbers(n, "scale", &at, 3)?;
            if let Some(m) = &matrix {
                if t.is_some() || r.is_some() || s.is_some() {
                    return Err(format!(
                        "{at}: has both a matrix and translation/rotation/scale (the specification allows one or the other)"
                    ));
                }
                if m[3] != 0.0 || m[7] != 0.0 || m[11] != 0.0 || m[15] != 1.0 {
                    return Err(format!(
                        "{at}.matrix: not an affine transform (its last row must be 0 0 0 1)"
                    ));
                }
            }
            if let Some(q) = &r {
                let len = q.iter().map(|x| x * x).sum::<f64>().sqrt();
                if (len - 1.0).abs() > 1e-2 {
                    return Err(format!(
                        "{at}.rotation: {q:?} is not a unit quaternion (length {len})"
                    ));
                }
            }
        }
        // With at most one parent each, a node no root reaches lies on a cycle.
        let mut reached = vec![false; nodes.len()];
        let mut stack: Vec<usize> = (0..nodes.len()).filter(|&i| parent[i].is_none()).collect();
        while let Some(i) = stack.pop() {
            reached[i] = true;
            for c in array(&nodes[i], "children", "")? {
                stack.extend(c.as_u64().map(|c| c as usize));
            }
        }
        if let Some(i) = reached.iter().position(|r| !r) {
            return Err(format!(
                "nodes[{i}]: lies on a cycle of the node hierarchy (it must be a set of trees)"
            ));
        }
        self.parents = parent;
        Ok(())
    }

    pub(super) fn scenes(&mut self) -> Result<(), String> {
        self.reference(self.root, "scene", "", "scenes")?;
        for (i, s) in array(self.root, "scenes", "")?.iter().enumerate() {
            let at = format!("scenes[{i}]");
            // Where each node was listed first.
            let mut listed = std::collections::HashMap::new();
            for (k, n) in self
                .references(s, "nodes", &at, "nodes")?
                .into_iter()
                .enumerate()
            {
                if let Some(p) = self.parents[n] {
                    return Err(format!(
                        "{at}.nodes[{k}]: node {n} is not a root node (it is a child of node {p})"
                    ));
                }
                // The schema's uniqueItems: a node has at most one place in the scene's
                // hierarchy, and listed twice it would be drawn twice on itself.
                if let Some(first) = listed.insert(n, k) {
                    return Err(format!(
                        "{at}.nodes: node {n} is listed twice (at {first} and {k}; a scene's root nodes must be unique)"
                    ));
                }
            }
        }
        Ok(())
    }

    pub(super) fn skins_and_animations(&mut self) -> Result<(), String> {
        for (i, s) in array(self.root, "skins", "")?.iter().enumerate() {
            let at = format!("skins[{i}]");
            self.reference(s, "inverseBindMatrices", &at, "accessors")?;
            self.reference(s, "skeleton", &at, "nodes")?;
            if self.references(s, "joints", &at, "nodes")?.is_empty() {
                return Err(format!("{at}.joints: missing or empty (required)"));
            }
        }
        for (i, a) in array(self.root, "animations", "")?.iter().enumerate() {
            let at = format!("animations[{i}]");
            let samplers = array(a, "samplers", &at)?;
            for (k, s) in samplers.iter().enumerate() {
                let here = format!("{at}.samplers[{k}]");
                self.required(s, "input", &here, "accessors")?;
                self.required(s, "output", &here, "accessors")?;
            }
            for (k, c) in array(a, "channels", &at)?.iter().enumerate() {
                let here = format!("{at}.channels[{k}]");
                let s = uint(c, "sampler", &here)?
                    .ok_or_else(|| format!("{here}.sampler: missing (required)"))?;
                if s as usize >= samplers.len() {
                    return Err(format!(
                        "{here}.sampler: sampler {s} does not exist (the animation has {})",
                        samplers.len()
                    ));
                }
                let target = c
                    .get("target")
                    .filter(|t| t.is_object())
                    .ok_or_else(|| format!("{here}.target: missing (required)"))?;
                self.reference(target, "node", &format!("{here}.target"), "nodes")?;
            }
        }
        Ok(())
    }
}
