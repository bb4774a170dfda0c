//! Export a scene description to Mitsuba 3 XML.
