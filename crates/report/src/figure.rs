//! A figure of the report: a PNG and the words around it.

/// One embedded image of the HTML page.
#[derive(Debug, Clone)]
pub struct Figure {
    /// Stable identifier, used as the HTML anchor and file stem ("top_view").
    pub id: String,
    pub title: String,
    /// One or two sentences saying what the reader sees (colours, units).
    pub caption: String,
    pub width: u32,
    pub height: u32,
    /// Encoded PNG bytes.
    pub png: Vec<u8>,
}
