//! The ascii PLY body: whitespace-separated tokens, read property by
//! property, with every error at the line where it was found.

use super::header::{Element, Header, Kind, Role};
use super::sink::Sink;
use crate::error::MeshError;
use crate::io::line_error;
use crate::io::text;

/// Whitespace-separated tokens of an ascii body, counting lines as it goes.
struct Tokens<'a> {
    rest: &'a [u8],
    line: u64,
}

impl<'a> Tokens<'a> {
    #[inline]
    fn next(&mut self) -> Option<&'a [u8]> {
        let mut i = 0;
        while let Some(&b) = self.rest.get(i) {
            if b == b'\n' {
                self.line += 1;
            } else if !text::is_space(b) {
                break;
            }
            i += 1;
        }
        let rest = self.rest.get(i..).unwrap_or_default();
        let end = rest.iter().position(|&b| b == b'\n' || text::is_space(b)).unwrap_or(rest.len());
        let (token, tail) = rest.split_at(end);
        self.rest = tail;
        (!token.is_empty()).then_some(token)
    }
}

/// Reads every element of the body, which starts on line `header.body_line`.
pub(super) fn read_body(
    header: &Header,
    body: &[u8],
    out: &mut Sink,
    name: &str,
) -> Result<(), MeshError> {
    let mut tokens = Tokens { rest: body, line: header.body_line };
    for element in &header.elements {
        read_element(element, &mut tokens, out, name)?;
    }
    if tokens.next().is_some() {
        out.notes.push(format!(
            "data after the elements the header declares (from line {}) was ignored",
            tokens.line
        ));
    }
    Ok(())
}

fn read_element<'a>(
    element: &Element,
    tokens: &mut Tokens<'a>,
    out: &mut Sink,
    name: &str,
) -> Result<(), MeshError> {
    if element.props.is_empty() {
        return Ok(());
    }
    let is_vertex = element.props.iter().any(|p| matches!(p.role, Role::Value(_)));
    let mut values = [0.0f64; 8];
    for k in 0..element.count {
        let next = |tokens: &mut Tokens<'a>| -> Result<&'a [u8], MeshError> {
            let line = tokens.line;
            tokens.next().ok_or_else(|| {
                let msg = format!(
                    "the file ends inside '{}' element {k} of {}",
                    element.name, element.count
                );
                line_error(name, line, msg)
            })
        };
        let mut first_line = None;
        for prop in &element.props {
            let token = next(tokens)?;
            first_line.get_or_insert(tokens.line);
            let bad_number = |tokens: &Tokens| {
                line_error(
                    name,
                    tokens.line,
                    format!("{} is not a number", text::show(Some(token))),
                )
            };
            match (prop.kind, prop.role) {
                (Kind::Scalar(_), Role::Value(slot)) => {
                    values[slot] = text::parse_f64(token).ok_or_else(|| bad_number(tokens))?;
                }
                (Kind::Scalar(_), _) => {}
                (Kind::List { .. }, role) => {
                    let n = text::parse_u64(token).ok_or_else(|| bad_number(tokens))?;
                    let line = tokens.line;
                    for _ in 0..n {
                        let item = next(tokens)?;
                        if role == Role::Indices {
                            let index = text::parse_i64(item).ok_or_else(|| {
                                line_error(
                                    name,
                                    tokens.line,
                                    format!("{} is not an integer", text::show(Some(item))),
                                )
                            })?;
                            out.corner(index).map_err(|msg| line_error(name, line, msg))?;
                        }
                    }
                    if role == Role::Indices {
                        out.end_face().map_err(|msg| line_error(name, line, msg))?;
                    }
                }
            }
        }
        if is_vertex {
            let line = first_line.unwrap_or(tokens.line);
            out.vertex(&values).map_err(|bad| {
                line_error(name, line, format!("vertex coordinate {bad} is not finite"))
            })?;
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::super::fixtures::{assert_fails_at_lines, parse, PYRAMID_FACES, SQUARE_PYRAMID};
    use crate::io::VertexAttributes;

    #[test]
    fn reads_ascii_with_extra_properties_elements_and_a_quad() {
        let text = "ply\r\nformat ascii 1.0\r\ncomment made by hand\r\nobj_info nothing\r\n\
            element vertex 5\r\nproperty float x\r\nproperty float y\r\nproperty float z\r\n\
            property uchar red\r\nproperty list uchar float extra\r\n\
            element edge 2\r\nproperty list int int ends\r\nproperty uchar tag\r\n\
            element face 5\r\nproperty list uchar int vertex_indices\r\nproperty float quality\r\n\
            end_header\r\n\
            0 0 0 1 0\r\n1 0 0 2 2 0.5 0.5\r\n1 1 0 3 0\r\n0 1 0 4 1 7\r\n0.5 0.5 1 5 0\r\n\
            2 0 1 9\r\n2 1 2 9\r\n\
            4 0 3 2 1 0.1\r\n3 0 1 4 0.2\r\n3 1 2 4 0.3\r\n3 2 3 4 0.4\r\n3 3 0 4 0.5\r\n";
        let loaded = parse(text.as_bytes()).unwrap();
        assert_eq!(loaded.mesh.positions(), &SQUARE_PYRAMID);
        assert_eq!(loaded.mesh.faces(), &PYRAMID_FACES);
        assert_eq!(loaded.attributes, VertexAttributes::default());
        assert_eq!(
            loaded.notes,
            vec![
                "1 polygons with more than 3 vertices were fan-triangulated into 2 triangles"
                    .to_string(),
                "ignored the 2 records of element 'edge' (header line 11): spherify reads the \
                 vertex and face elements only"
                    .to_string()
            ]
        );
    }

    #[test]
    fn malformed_ascii_data_is_reported_by_line() {
        assert_fails_at_lines(&[
            ("1 0 0\n", "1 x 0\n", 11),
            ("0 1 0\n", "0 1 inf\n", 12),
            ("3 0 1 2", "3 0 1 3", 13),
            ("3 0 1 2", "3 0 1 -1", 13),
            ("3 0 1 2", "2 0 1 2", 13),
            ("3 0 1 2", "3 0 1 z", 13),
            ("3 0 1 2\n", "3 0\n\n\n\n", 13),
        ]);
    }
}
